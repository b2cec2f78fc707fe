#!/usr/bin/env bash
# Installs polarnav as a system service: binaries, configuration, systemd
# units, sysusers.d/tmpfiles.d entries and documentation.
#
#   cargo build --release && sudo scripts/install.sh
#   DESTDIR=/tmp/stage scripts/install.sh      # stage for a package or image
#   BIN_DIR=target/aarch64-unknown-linux-gnu/release DESTDIR=... scripts/install.sh
#
# PREFIX (default /usr/local) holds bin/ and share/doc/polarnav/; the units
# expect /usr/local/bin. An existing /etc/polarnav/nav-daemon.toml is kept
# (the shipped one is installed beside it as nav-daemon.toml.dist). Without
# DESTDIR, on a machine run by systemd, the user, group and directories are
# created and systemd reloaded; nothing is enabled or started.
set -euo pipefail
cd "$(dirname "$0")/.."
DESTDIR=${DESTDIR:-}
PREFIX=${PREFIX:-/usr/local}
BIN_DIR=${BIN_DIR:-target/release}

for b in nav-daemon sensor-replay; do
  [ -x "$BIN_DIR/$b" ] || { echo "install: $BIN_DIR/$b not built (cargo build --release)" >&2; exit 2; }
done
install -d -m 0755 "$DESTDIR$PREFIX/bin" "$DESTDIR$PREFIX/share/doc/polarnav" \
  "$DESTDIR/etc/systemd/system" "$DESTDIR/etc/sysusers.d" "$DESTDIR/etc/tmpfiles.d"
install -d -m 0755 "$DESTDIR/etc/polarnav"
install -m 0755 "$BIN_DIR/nav-daemon" "$BIN_DIR/sensor-replay" "$DESTDIR$PREFIX/bin/"
install -m 0644 systemd/nav-daemon.service systemd/nav-recorder.service \
  systemd/sensor-replay@.service "$DESTDIR/etc/systemd/system/"
install -m 0644 systemd/polarnav.sysusers "$DESTDIR/etc/sysusers.d/polarnav.conf"
install -m 0644 systemd/polarnav.tmpfiles "$DESTDIR/etc/tmpfiles.d/polarnav.conf"
install -m 0644 README.md "$DESTDIR$PREFIX/share/doc/polarnav/README.md"
install -m 0644 msgs/include/polarnav_msgs.h "$DESTDIR$PREFIX/share/doc/polarnav/"
if [ -e "$DESTDIR/etc/polarnav/nav-daemon.toml" ]; then
  install -m 0644 config/nav-daemon.toml "$DESTDIR/etc/polarnav/nav-daemon.toml.dist"
  echo "install: kept /etc/polarnav/nav-daemon.toml (the shipped one is nav-daemon.toml.dist)"
else
  install -m 0644 config/nav-daemon.toml "$DESTDIR/etc/polarnav/nav-daemon.toml"
fi
# The installed configuration must pass the daemon's own check (skipped for
# a binary of another architecture, which cannot run here).
if "$DESTDIR$PREFIX/bin/nav-daemon" --version >/dev/null 2>&1; then
  "$DESTDIR$PREFIX/bin/nav-daemon" --check-config "$DESTDIR/etc/polarnav/nav-daemon.toml" >/dev/null
fi
if [ -z "$DESTDIR" ] && [ -d /run/systemd/system ]; then
  systemd-sysusers /etc/sysusers.d/polarnav.conf
  systemd-tmpfiles --create /etc/tmpfiles.d/polarnav.conf
  systemctl daemon-reload
  echo "install: done; start with: systemctl enable --now nav-daemon.service"
else
  echo "install: staged under ${DESTDIR:-/} (user, group and directories are created at boot by systemd-sysusers and systemd-tmpfiles)"
fi
