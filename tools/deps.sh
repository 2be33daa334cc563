#!/usr/bin/env bash
# Installs the Debian packages that every build and test of edgefuse needs (host, host-fixed,
# host-asan, aarch64 and armhf under qemu-user). Idempotent and fast when all are present: CI runs it
# on every submission, often on a machine that already has them.
set -euo pipefail

PACKAGES=(
  build-essential cmake ninja-build pkg-config file
  libeigen3-dev libcpputest-dev cpputest libpng-dev libtomlplusplus-dev liblzf-dev
  g++-aarch64-linux-gnu g++-arm-linux-gnueabihf qemu-user
  python3 python3-numpy
  # pose link: nanopb generator + runtime, protoc and Python protobuf for
  # tools/listen.py and its tests
  nanopb libnanopb-dev protobuf-compiler python3-protobuf
  # HAL device backends: OpenNI2 (with its Dummy test device), libgpiod 1.6, libusb 1.0;
  # V4L2 needs only linux/videodev2.h (linux-libc-dev, with the compiler).
  libopenni2-dev libgpiod-dev libusb-1.0-0-dev
  # Debian packages (tools/package, test_package_install): cpack's dpkg-shlibdeps, lintian, and
  # systemd-analyze for the unit
  dpkg-dev lintian systemd
)

missing=()
for p in "${PACKAGES[@]}"; do
  # 'install ok installed' only: a package that was removed keeps a 'deinstall' record.
  if [[ "$(dpkg-query -W -f='${db:Status-Abbrev}' "$p" 2>/dev/null)" != ii* ]]; then
    missing+=("$p")
  fi
done
if ((${#missing[@]} == 0)); then
  echo "deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=()
if ((EUID != 0)); then
  SUDO=(sudo)
fi
export DEBIAN_FRONTEND=noninteractive
echo "deps: installing ${missing[*]}"
# The package lists of a fresh machine may be empty or stale: update only when something is missing.
"${SUDO[@]}" apt-get update -qq || echo "deps: apt-get update reported errors; trying the install anyway" >&2
"${SUDO[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
  -o Dpkg::Use-Pty=0 "${missing[@]}"
