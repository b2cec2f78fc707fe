/* Every code of libpolarnav_pub provoked through its C ABI and named, and
 * the library's behaviour against a daemon that is not reading.
 *
 *   codes PREFIX MODE
 *
 * MODE "errors": provokes each error and warning code it can on PREFIX,
 *   printing "CODE_NAME ok" for each (exit 1 at the first surprise). The
 *   test has squatted PREFIX/cns with another payload type.
 * MODE "second": opens a second IMU publisher (PN_W_SECOND_PUBLISHER),
 *   publishes 200 samples at 200 Hz, prints "second sent=N".
 * MODE "stalled": publishes 20000 IMU samples as fast as it can into a
 *   subscriber that never reads, prints "stalled sent=N lost=L seconds=S".
 * MODE "transport": opens imu where iceoryx2 cannot work (the test points
 *   POLARNAV_IOX_ROOT at a file): PN_E_TRANSPORT.
 * PN_E_INTERNAL (a panic inside the library) has no way in from C. */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "polarnav_pub.h"

static int expect(int32_t got, int32_t want, const char *what) {
  if (got != want) {
    fprintf(stderr, "%s: got %s (%d), expected %s: %s\n", what, pn_error_name(got), got, pn_error_name(want),
            pn_last_error_detail());
    return 1;
  }
  printf("%s ok (%s: %s)\n", pn_error_name(want), what, pn_last_error_detail());
  return 0;
}

static double now_s(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static ImuSample imu(uint64_t k) {
  ImuSample s;
  memset(&s, 0, sizeof s);
  s.t_ns = 1000000000ull + k * 5000000ull;
  s.seq = k;
  s.dt_s = 0.005;
  s.d_v_mps[2] = 9.8 * 0.005;
  return s;
}

static int errors(const char *prefix) {
  int bad = 0;
  int32_t err = 0;
  PnPublisher *p;
  p = pn_publisher_open(prefix, NULL, &err);
  bad |= expect(err, PN_E_NULL, "open with a NULL stream") | (p != NULL);
  p = pn_publisher_open("bad prefix", "imu", &err);
  bad |= expect(err, PN_E_BAD_PREFIX, "open under \"bad prefix\"") | (p != NULL);
  p = pn_publisher_open(prefix, "lidar", &err);
  bad |= expect(err, PN_E_UNKNOWN_STREAM, "open stream \"lidar\"") | (p != NULL);
  p = pn_publisher_open(prefix, "cns", &err);
  bad |= expect(err, PN_E_INCOMPATIBLE_SERVICE, "open cns, squatted with another type") | (p != NULL);

  PnPublisher *imu_pub = pn_publisher_open(prefix, "imu", &err);
  bad |= expect(err, PN_OK, "open imu") | (imu_pub == NULL);
  if (!imu_pub) return 1;
  PnPublisher *again = pn_publisher_open(prefix, "imu", &err);
  bad |= expect(err, PN_W_SECOND_PUBLISHER, "open imu twice") | (again == NULL);
  pn_publisher_close(again);

  ImuSample s = imu(1);
  bad |= expect(pn_publish_imu(imu_pub, &s), PN_OK, "publish an IMU sample");
  bad |= expect(pn_publish_imu(imu_pub, NULL), PN_E_NULL, "publish NULL");
  bad |= expect(pn_publish_imu(NULL, &s), PN_E_NULL, "publish on NULL");
  ImuSample nan = imu(2);
  nan.d_theta_rad[1] = NAN;
  bad |= expect(pn_publish_imu(imu_pub, &nan), PN_E_NOT_FINITE, "publish a NaN rate");
  ImuSample inf = imu(2);
  inf.dt_s = INFINITY;
  bad |= expect(pn_publish_imu(imu_pub, &inf), PN_E_NOT_FINITE, "publish an infinite interval");
  bad |= expect(pn_publish_imu(imu_pub, &s), PN_E_STAMP_NOT_INCREASING, "publish the same stamp again");
  ImuSample back = imu(0);
  bad |= expect(pn_publish_imu(imu_pub, &back), PN_E_STAMP_NOT_INCREASING, "publish an earlier stamp");
  GnssFix fix;
  memset(&fix, 0, sizeof fix);
  fix.t_ns = 2000000000ull;
  bad |= expect(pn_publish_gnss(imu_pub, &fix), PN_E_WRONG_STREAM, "publish a GNSS fix on the imu publisher");
  if (pn_publisher_refused(imu_pub) != 4 || pn_publisher_sent(imu_pub) != 1) {
    fprintf(stderr, "refused %llu sent %llu, expected 4 and 1\n", (unsigned long long)pn_publisher_refused(imu_pub),
            (unsigned long long)pn_publisher_sent(imu_pub));
    bad = 1;
  }
  pn_publisher_close(imu_pub);
  pn_publisher_close(NULL);
  if (strcmp(pn_error_name(12345), "PN_UNKNOWN_CODE") != 0) bad = 1;
  printf("unknown code: %s, %s\n", pn_error_name(12345), pn_error_message(12345));
  return bad;
}

static int second(const char *prefix) {
  int32_t err = 0;
  PnPublisher *p = pn_publisher_open(prefix, "imu", &err);
  if (!p || expect(err, PN_W_SECOND_PUBLISHER, "open a second imu publisher")) return 1;
  unsigned sent = 0;
  for (uint64_t k = 0; k < 200; k++) {
    /* Stamps far in the future of the flight: only the daemon's publisher
     * rule keeps them out. */
    ImuSample s = imu(k);
    s.t_ns += 1000000000000ull;
    if (pn_publish_imu(p, &s) == PN_OK) sent++;
    struct timespec d = {0, 5000000};
    nanosleep(&d, NULL);
  }
  printf("second sent=%u\n", sent);
  pn_publisher_close(p);
  return sent == 200 ? 0 : 1;
}

static int stalled(const char *prefix) {
  int32_t err = 0;
  PnPublisher *p = pn_publisher_open(prefix, "imu", &err);
  if (!p || expect(err, PN_OK, "open imu")) return 1;
  double t0 = now_s();
  unsigned sent = 0;
  for (uint64_t k = 0; k < 20000; k++) {
    ImuSample s = imu(k);
    if (pn_publish_imu(p, &s) == PN_OK) sent++;
  }
  printf("stalled sent=%u lost=%llu seconds=%.3f\n", sent, (unsigned long long)pn_publisher_lost(p), now_s() - t0);
  pn_publisher_close(p);
  return 0;
}

int main(int argc, char **argv) {
  if (argc != 3) {
    fprintf(stderr, "usage: codes PREFIX errors|second|stalled|transport\n");
    return 2;
  }
  if (!strcmp(argv[2], "errors")) return errors(argv[1]);
  if (!strcmp(argv[2], "second")) return second(argv[1]);
  if (!strcmp(argv[2], "stalled")) return stalled(argv[1]);
  if (!strcmp(argv[2], "transport")) {
    int32_t err = 0;
    PnPublisher *p = pn_publisher_open(argv[1], "imu", &err);
    return expect(err, PN_E_TRANSPORT, "open imu without shared memory") | (p != NULL);
  }
  return 2;
}
