/* Publishes a flight into polarnav through libpolarnav_pub, as a C sensor
 * driver would: the records of a feed file (written by the test from a
 * simulated navlog: u32 stream tag, u32 payload size, the payload's bytes
 * as polarnav_msgs.h lays them out) at `speed` times their stamps' pace.
 *
 *   feed PREFIX FILE SPEED
 *
 * Tags: 0 init, 1 imu, 2 + k the aid of AidKind k. Exit 0 when every
 * record was published; prints the counts of each stream. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "polarnav_pub.h"

#define STREAMS (2 + POLARNAV_AID_COUNT)

/* Tag 0 init, 1 imu, 2 + k the aid k, named by the library. */
static const char *stream_name(uint32_t tag) {
  return tag == 0 ? "init" : tag == 1 ? "imu" : pn_aid_name(tag - 2);
}

static double now_s(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static void sleep_until(double t) {
  double d = t - now_s();
  if (d <= 0) return;
  struct timespec s = {(time_t)d, (long)((d - (double)(time_t)d) * 1e9)};
  while (nanosleep(&s, &s) == -1 && errno == EINTR) {
  }
}

int main(int argc, char **argv) {
  if (argc != 4) {
    fprintf(stderr, "usage: feed PREFIX FILE SPEED\n");
    return 2;
  }
  const char *prefix = argv[1];
  double speed = atof(argv[3]);
  FILE *f = fopen(argv[2], "rb");
  if (!f) {
    perror(argv[2]);
    return 2;
  }
  PnPublisher *pubs[STREAMS] = {0};
  unsigned long long sent[STREAMS] = {0};
  static _Alignas(16) unsigned char buf[4096];
  uint32_t head[2];
  double t0_wall = 0;
  uint64_t t0_ns = 0;
  int first = 1;
  while (fread(head, sizeof head, 1, f) == 1) {
    uint32_t tag = head[0], size = head[1];
    if (tag >= STREAMS || size > sizeof buf || fread(buf, size, 1, f) != 1) {
      fprintf(stderr, "feed: bad record (tag %u, size %u)\n", tag, size);
      return 1;
    }
    if (!pubs[tag]) {
      int32_t err = 0;
      pubs[tag] = pn_publisher_open(prefix, stream_name(tag), &err);
      if (!pubs[tag] || err != PN_OK) {
        fprintf(stderr, "feed: open %s: %s (%s): %s\n", stream_name(tag), pn_error_name(err),
                pn_error_message(err), pn_last_error_detail());
        return 1;
      }
    }
    /* Every payload starts with its stamp (t_ns). */
    uint64_t t_ns;
    memcpy(&t_ns, buf, sizeof t_ns);
    if (first) {
      t0_wall = now_s();
      t0_ns = t_ns;
      first = 0;
    }
    if (t_ns > t0_ns) sleep_until(t0_wall + (double)(t_ns - t0_ns) * 1e-9 / speed);
    int32_t rc;
    switch (tag) {
      case 0: rc = pn_publish_init(pubs[tag], (const InitState *)buf); break;
      case 1: rc = pn_publish_imu(pubs[tag], (const ImuSample *)buf); break;
      case 2 + AidKind_Srs: rc = pn_publish_srs(pubs[tag], (const SrsSample *)buf); break;
      case 2 + AidKind_Cns: rc = pn_publish_cns(pubs[tag], (const CnsFix *)buf); break;
      case 2 + AidKind_Baro: rc = pn_publish_baro(pubs[tag], (const BaroSample *)buf); break;
      case 2 + AidKind_Star: rc = pn_publish_star(pubs[tag], (const StarSample *)buf); break;
      case 2 + AidKind_Gnss: rc = pn_publish_gnss(pubs[tag], (const GnssFix *)buf); break;
      case 2 + AidKind_Baseline: rc = pn_publish_baseline(pubs[tag], (const BaselineSample *)buf); break;
      case 2 + AidKind_Mag: rc = pn_publish_mag(pubs[tag], (const MagSample *)buf); break;
      default: rc = PN_E_UNKNOWN_STREAM;
    }
    if (rc != PN_OK) {
      fprintf(stderr, "feed: publish %s at %llu ns: %s: %s\n", stream_name(tag), (unsigned long long)t_ns,
              pn_error_name(rc), pn_last_error_detail());
      return 1;
    }
    sent[tag]++;
  }
  if (ferror(f)) {
    perror("feed: read");
    return 1;
  }
  for (int k = 0; k < STREAMS; k++) {
    if (pubs[k]) {
      printf("%s sent=%llu lost=%llu refused=%llu\n", stream_name((uint32_t)k), sent[k],
             (unsigned long long)pn_publisher_lost(pubs[k]),
             (unsigned long long)pn_publisher_refused(pubs[k]));
      pn_publisher_close(pubs[k]);
    }
  }
  return 0;
}
