#!/usr/bin/env bash
# Installs polarnav as a system service: binaries, configuration, systemd
# units, sysusers.d/tmpfiles.d entries, documentation, shell completions
# (bash, zsh, fish) and manual pages.
#
#   cargo build --release && sudo scripts/install.sh
#   DESTDIR=/tmp/stage scripts/install.sh      # stage for a package or image
#   BIN_DIR=target/aarch64-unknown-linux-gnu/release DESTDIR=... scripts/install.sh
#
# PREFIX (default /usr/local) holds bin/ and share/doc/polarnav/; the
# installed units start $PREFIX/bin/... and name $PREFIX/share/doc/polarnav
# (the units in systemd/ say /usr/local, rewritten here). An existing /etc/polarnav/nav-daemon.toml is kept
# (the shipped one is installed beside it as nav-daemon.toml.dist; the same
# for gnss-ubx.toml, nav-mavlink.toml and nav-nmea.toml). Without
# DESTDIR, on a machine run by systemd, the user, group and directories are
# created and systemd reloaded; nothing is enabled or started.
set -euo pipefail
cd "$(dirname "$0")/.."
DESTDIR=${DESTDIR:-}
PREFIX=${PREFIX:-/usr/local}
BIN_DIR=${BIN_DIR:-target/release}
# PREFIX goes into the units' ExecStart= and sed's replacement: an absolute
# path of plain characters only.
case "$PREFIX" in
  /*) ;;
  *) echo "install: PREFIX must be an absolute path, got '$PREFIX'" >&2; exit 2 ;;
esac
case "$PREFIX" in
  *[!A-Za-z0-9/._+-]*) echo "install: PREFIX may hold only A-Z a-z 0-9 / . _ + -, got '$PREFIX'" >&2; exit 2 ;;
esac
PREFIX=${PREFIX%/}

for b in nav-daemon sensor-replay gnss-ubx nav-mavlink nav-nmea; do
  [ -x "$BIN_DIR/$b" ] || { echo "install: $BIN_DIR/$b not built (cargo build --release)" >&2; exit 2; }
done
install -d -m 0755 "$DESTDIR$PREFIX/bin" "$DESTDIR$PREFIX/share/doc/polarnav" \
  "$DESTDIR/etc/systemd/system" "$DESTDIR/etc/sysusers.d" "$DESTDIR/etc/tmpfiles.d"
install -d -m 0755 "$DESTDIR/etc/polarnav"
install -m 0755 "$BIN_DIR/nav-daemon" "$BIN_DIR/sensor-replay" "$BIN_DIR/gnss-ubx" \
  "$BIN_DIR/nav-mavlink" "$BIN_DIR/nav-nmea" "$DESTDIR$PREFIX/bin/"
units="nav-daemon.service nav-recorder.service nav-view.service sensor-replay@.service
  gnss-ubx.service nav-mavlink.service nav-mavlink.socket nav-nmea.service nav-nmea.socket"
for u in $units; do
  # The units start the binaries where this script puts them.
  sed -e "s|/usr/local/bin/|$PREFIX/bin/|g" \
      -e "s|file:/usr/local/share/doc/polarnav/|file:$PREFIX/share/doc/polarnav/|g" \
      "systemd/$u" >"$DESTDIR/etc/systemd/system/$u.tmp"
  chmod 0644 "$DESTDIR/etc/systemd/system/$u.tmp"
  mv "$DESTDIR/etc/systemd/system/$u.tmp" "$DESTDIR/etc/systemd/system/$u"
done
install -m 0644 systemd/polarnav.sysusers "$DESTDIR/etc/sysusers.d/polarnav.conf"
install -m 0644 systemd/polarnav.tmpfiles "$DESTDIR/etc/tmpfiles.d/polarnav.conf"
install -m 0644 README.md "$DESTDIR$PREFIX/share/doc/polarnav/README.md"
install -m 0644 msgs/include/polarnav_msgs.h "$DESTDIR$PREFIX/share/doc/polarnav/"
# libpolarnav_pub, the C ABI of the input publishers: the shared and the
# static library, its header and the payloads' in $PREFIX/include/polarnav,
# and a pkg-config file (cc driver.c $(pkg-config --cflags --libs polarnav_pub)).
if [ -e "$BIN_DIR/libpolarnav_pub.so" ]; then
  install -d -m 0755 "$DESTDIR$PREFIX/lib/pkgconfig" "$DESTDIR$PREFIX/include/polarnav"
  install -m 0755 "$BIN_DIR/libpolarnav_pub.so" "$DESTDIR$PREFIX/lib/"
  [ -e "$BIN_DIR/libpolarnav_pub.a" ] && install -m 0644 "$BIN_DIR/libpolarnav_pub.a" "$DESTDIR$PREFIX/lib/"
  install -m 0644 msgs/include/polarnav_msgs.h msgs/include/polarnav_pub.h "$DESTDIR$PREFIX/include/polarnav/"
  version=$(sed -n 's/^version = "\(.*\)"/\1/p' Cargo.toml | head -1)
  cat >"$DESTDIR$PREFIX/lib/pkgconfig/polarnav_pub.pc" <<PC
prefix=$PREFIX
libdir=\${prefix}/lib
includedir=\${prefix}/include/polarnav

Name: polarnav_pub
Description: Publish polarnav's inputs (IMU, aids, init) from C or C++ over iceoryx2
Version: $version
Libs: -L\${libdir} -lpolarnav_pub
Libs.private: -lpthread -ldl -lm
Cflags: -I\${includedir}
PC
  chmod 0644 "$DESTDIR$PREFIX/lib/pkgconfig/polarnav_pub.pc"
else
  echo "install: $BIN_DIR/libpolarnav_pub.so not built (cargo build --release -p polarnav-pub): the C publisher library is not installed"
fi
for c in nav-daemon.toml gnss-ubx.toml nav-mavlink.toml nav-nmea.toml; do
  if [ -e "$DESTDIR/etc/polarnav/$c" ]; then
    install -m 0644 "config/$c" "$DESTDIR/etc/polarnav/$c.dist"
    echo "install: kept /etc/polarnav/$c (the shipped one is $c.dist)"
  else
    install -m 0644 "config/$c" "$DESTDIR/etc/polarnav/$c"
  fi
done
# The installed configuration must pass the daemon's own check, and the
# binaries write their shell completions and manual pages (both skipped for
# a binary of another architecture, which cannot run here).
if "$DESTDIR$PREFIX/bin/nav-daemon" --version >/dev/null 2>&1; then
  "$DESTDIR$PREFIX/bin/nav-daemon" --check-config "$DESTDIR/etc/polarnav/nav-daemon.toml" >/dev/null
  "$DESTDIR$PREFIX/bin/gnss-ubx" --check-config "$DESTDIR/etc/polarnav/gnss-ubx.toml" >/dev/null
  "$DESTDIR$PREFIX/bin/nav-mavlink" --check-config "$DESTDIR/etc/polarnav/nav-mavlink.toml" >/dev/null
  "$DESTDIR$PREFIX/bin/nav-nmea" --check-config "$DESTDIR/etc/polarnav/nav-nmea.toml" >/dev/null
  share="$DESTDIR$PREFIX/share"
  install -d -m 0755 "$share/bash-completion/completions" "$share/zsh/site-functions" \
    "$share/fish/vendor_completions.d" "$share/man/man1"
  for b in nav-daemon sensor-replay; do
    "$DESTDIR$PREFIX/bin/$b" completions bash >"$share/bash-completion/completions/$b"
    "$DESTDIR$PREFIX/bin/$b" completions zsh >"$share/zsh/site-functions/_$b"
    "$DESTDIR$PREFIX/bin/$b" completions fish >"$share/fish/vendor_completions.d/$b.fish"
    "$DESTDIR$PREFIX/bin/$b" man >"$share/man/man1/$b.1"
  done
  chmod 0644 "$share/bash-completion/completions/"{nav-daemon,sensor-replay} \
    "$share/zsh/site-functions/"_{nav-daemon,sensor-replay} \
    "$share/fish/vendor_completions.d/"{nav-daemon,sensor-replay}.fish \
    "$share/man/man1/"{nav-daemon,sensor-replay}.1
else
  echo "install: $BIN_DIR/nav-daemon does not run here: configuration not checked, no completions or man pages (run 'nav-daemon completions bash' and 'nav-daemon man' on the target)"
fi
if [ -z "$DESTDIR" ] && [ -d /run/systemd/system ]; then
  systemd-sysusers /etc/sysusers.d/polarnav.conf
  systemd-tmpfiles --create /etc/tmpfiles.d/polarnav.conf
  systemctl daemon-reload
  echo "install: done; start with: systemctl enable --now nav-daemon.service (and gnss-ubx.service once /etc/polarnav/gnss-ubx.toml names the receiver's port)"
else
  echo "install: staged under ${DESTDIR:-/} (user, group and directories are created at boot by systemd-sysusers and systemd-tmpfiles)"
fi
