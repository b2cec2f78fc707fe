/* An IMU driver in C on libpolarnav_pub: a KVH 1750 on RS-422, its 36-byte
 * binary message read from a serial port and published on <prefix>/imu.
 *
 *   kvh1750 DEVICE PREFIX RATE_HZ [rates|increments]
 *
 *   cc -std=c11 -O2 kvh1750.c $(pkg-config --cflags --libs polarnav_pub) -o kvh1750
 *   (or CMake: see CMakeLists.txt beside this file)
 *
 * The message (all fields big-endian):
 *
 *   offset size  field
 *   0      4     header 0xFE 0x81 0xFF 0x55
 *   4      12    gyro x, y, z: IEEE-754 float, rad (increments) or rad/s (rates)
 *   16     12    accel x, y, z: float, m/s (increments) or m/s² (rates)
 *   28     1     status: bit 0-2 gyro x-z valid, bit 4-6 accel x-z valid
 *   29     1     sequence number, 0 to 127, +1 per sample
 *   30     2     temperature, signed, °C
 *   32     4     CRC-32 of bytes 0-31: polynomial 0x04C11DB7, initial
 *                0xFFFFFFFF, not reflected, no final XOR (CRC-32/MPEG-2)
 *
 * The unit's output (increments or rates, SI units) is configured on the
 * unit; say which on the command line. RATE_HZ is the unit's data rate.
 *
 * Framing: bytes are searched for the header; a message whose CRC fails
 * is dropped and the search resumes one byte after its header (a header
 * pattern inside a corrupted message must not cost the next good one).
 * A message with a sensor flagged invalid is dropped and counted.
 *
 * Time: the sensor's own sequence counter is the clock. The stamp of a
 * sample is the stamp of the first one plus its count of sensor periods
 * (the counter's steps, wrapped at 128), so serial and scheduling jitter
 * never enter the stamps. The first stamp is the arrival of the first
 * message's last byte on CLOCK_REALTIME (the flight computer's clock,
 * disciplined to GNSS time: the daemon's stamps) less the message's
 * transmission time at the line rate. When the stamps drift from the
 * arrivals (the sensor's oscillator against the computer's) by more than
 * RESYNC_NS, the origin is moved to the arrival and the move is counted:
 * the daemon sees a step in the stamps, never a silent slide.
 *
 * Increments: Δθ and Δv are the unit's own increments over its period.
 * Rates: Δθ = ω·T and Δv = f·T with T = 1/RATE_HZ (the rectangle rule on
 * the unit's sample, which is its average over the period when the unit
 * filters before decimating). A sequence gap of k periods (messages lost
 * on the line) leaves a gap of k periods in the stamps, with `dt_s` the one
 * period the sample covers: the daemon bridges or coasts the gap, it
 * never integrates a sample across time it did not cover.
 *
 * At the end (EOF on the device, or SIGINT/SIGTERM) it prints its counts. */
#define _DEFAULT_SOURCE /* cfmakeraw, B921600 */
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include "polarnav_pub.h"

#define MSG_LEN 36
#define BAUD 921600
#define RESYNC_NS 5000000ll /* 5 ms */

static volatile sig_atomic_t stop;
static void on_signal(int s) {
  (void)s;
  stop = 1;
}

/* CRC-32/MPEG-2, bit by bit (no table: 32 bytes per message). */
static uint32_t crc32_mpeg2(const unsigned char *p, size_t n) {
  uint32_t c = 0xFFFFFFFFu;
  for (size_t i = 0; i < n; i++) {
    c ^= (uint32_t)p[i] << 24;
    for (int b = 0; b < 8; b++) c = (c & 0x80000000u) ? (c << 1) ^ 0x04C11DB7u : c << 1;
  }
  return c;
}

static uint32_t be32(const unsigned char *p) {
  return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | (uint32_t)p[3];
}

static double be_float(const unsigned char *p) {
  uint32_t u = be32(p);
  float f;
  memcpy(&f, &u, sizeof f);
  return (double)f;
}

static int64_t now_ns(void) {
  struct timespec t;
  clock_gettime(CLOCK_REALTIME, &t);
  return (int64_t)t.tv_sec * 1000000000ll + t.tv_nsec;
}

static int open_serial(const char *dev) {
  int fd = open(dev, O_RDONLY | O_NOCTTY);
  if (fd < 0) return -1;
  struct termios t;
  if (tcgetattr(fd, &t) == 0) { /* a pty or a real port; a file has none */
    cfmakeraw(&t);
    cfsetispeed(&t, B921600);
    t.c_cc[VMIN] = 1;
    t.c_cc[VTIME] = 0;
    tcsetattr(fd, TCSANOW, &t);
  }
  return fd;
}

int main(int argc, char **argv) {
  if (argc < 4 || argc > 5) {
    fprintf(stderr, "usage: kvh1750 DEVICE PREFIX RATE_HZ [rates|increments]\n");
    return 2;
  }
  double rate_hz = atof(argv[3]);
  int rates = argc == 5 && strcmp(argv[4], "rates") == 0;
  if (!(rate_hz >= 1.0 && rate_hz <= 10000.0) || (argc == 5 && !rates && strcmp(argv[4], "increments") != 0)) {
    fprintf(stderr, "kvh1750: RATE_HZ must be 1 to 10000 and the output rates or increments\n");
    return 2;
  }
  const int64_t period_ns = (int64_t)(1e9 / rate_hz + 0.5);
  const double period_s = (double)period_ns * 1e-9;
  /* 10 bits per byte on the line (start, 8 data, stop). */
  const int64_t transmit_ns = (int64_t)(MSG_LEN * 10 * 1e9 / BAUD);

  struct sigaction sa;
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_signal;
  sigaction(SIGINT, &sa, NULL);
  sigaction(SIGTERM, &sa, NULL);

  int fd = open_serial(argv[1]);
  if (fd < 0) {
    perror(argv[1]);
    return 1;
  }
  int32_t err = 0;
  PnPublisher *pub = pn_publisher_open(argv[2], "imu", &err);
  if (!pub) {
    fprintf(stderr, "kvh1750: %s: %s\n", pn_error_name(err), pn_last_error_detail());
    return 1;
  }
  if (err != PN_OK) fprintf(stderr, "kvh1750: warning: %s: %s\n", pn_error_name(err), pn_last_error_detail());

  unsigned char buf[4096];
  size_t have = 0;
  unsigned long long messages = 0, bad_crc = 0, invalid = 0, gaps = 0, gap_periods = 0, resyncs = 0,
                     skipped_bytes = 0, published = 0, refused = 0;
  int first = 1;
  int prev_seq = 0;
  int64_t origin_ns = 0, periods = 0, last_t = 0;
  uint64_t out_seq = 0;
  while (!stop) {
    ssize_t n = read(fd, buf + have, sizeof buf - have);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break; /* EOF or a device error */
    int64_t arrival = now_ns();
    have += (size_t)n;
    size_t at = 0;
    while (have - at >= MSG_LEN) {
      const unsigned char *m = buf + at;
      if (be32(m) != 0xFE81FF55u) {
        at++;
        skipped_bytes++;
        continue;
      }
      if (crc32_mpeg2(m, 32) != be32(m + 32)) {
        bad_crc++;
        at++; /* resume the search inside the bad message */
        continue;
      }
      at += MSG_LEN;
      messages++;
      int seq = m[29];
      if ((m[28] & 0x77) != 0x77 || seq > 127) {
        invalid++;
        continue;
      }
      /* Sensor periods since the previous message (the counter wraps at 128). */
      int64_t step = first ? 0 : (seq - prev_seq + 128) % 128;
      if (!first && step == 0) step = 128; /* a whole lap lost: the most that can be told */
      if (step > 1) {
        gaps++;
        gap_periods += (unsigned long long)(step - 1);
      }
      prev_seq = seq;
      periods += step;
      /* The message's last byte arrived at most `arrival`: the sample's
       * time is earlier by the bytes after it in this read and the line. */
      int64_t seen = arrival - transmit_ns - (int64_t)((have - at) * 10 * 1e9 / BAUD);
      if (first) {
        origin_ns = seen;
        first = 0;
      }
      int64_t t = origin_ns + periods * period_ns;
      if (t - seen > RESYNC_NS || seen - t > RESYNC_NS) {
        resyncs++;
        /* Never back before the previous stamp: the daemon refuses it. */
        t = seen > last_t ? seen : last_t + 1;
        origin_ns = t - periods * period_ns;
      }
      last_t = t;
      ImuSample s;
      memset(&s, 0, sizeof s);
      s.t_ns = (uint64_t)t;
      s.seq = out_seq++;
      s.dt_s = period_s;
      double k = rates ? period_s : 1.0;
      for (int i = 0; i < 3; i++) {
        s.d_theta_rad[i] = be_float(m + 4 + 4 * i) * k;
        s.d_v_mps[i] = be_float(m + 16 + 4 * i) * k;
      }
      int32_t rc = pn_publish_imu(pub, &s);
      if (rc == PN_OK) {
        published++;
      } else {
        refused++;
        fprintf(stderr, "kvh1750: sample %llu: %s: %s\n", messages, pn_error_name(rc), pn_last_error_detail());
      }
    }
    memmove(buf, buf + at, have - at);
    have -= at;
  }
  printf("kvh1750: messages=%llu published=%llu refused=%llu bad_crc=%llu invalid=%llu gaps=%llu gap_periods=%llu "
         "resyncs=%llu skipped_bytes=%llu lost=%llu\n",
         messages, published, refused, bad_crc, invalid, gaps, gap_periods, resyncs, skipped_bytes,
         (unsigned long long)pn_publisher_lost(pub));
  pn_publisher_close(pub);
  close(fd);
  return 0;
}
