#!/usr/bin/env bash
# tools/sysroot.sh <arm64|armhf> <dest-dir>
#
# Fills <dest-dir> with Debian's <arch> libraries that the ARM builds link: the -dev packages and
# their library packages, fetched with `apt-get download` and unpacked with `dpkg -x` (never
# installed: the host's packages stay untouched). The cross toolchain files point
# CMAKE_FIND_ROOT_PATH at it. libc and libstdc++ are not here: they come with the Debian cross
# compilers (/usr/<triplet>), which is also where qemu-user finds them at run time (-L).
#
# Idempotent: a stamp file records what was unpacked; a rerun with the same package set is a no-op.
set -euo pipefail

usage() { echo "usage: $0 <arm64|armhf> <dest-dir>" >&2; exit 2; }
(($# == 2)) || usage
arch=$1
dest=$2
case "$arch" in
  arm64) triplet=aarch64-linux-gnu;   cflags="-mcpu=cortex-a72" ;;
  armhf) triplet=arm-linux-gnueabihf; cflags="-mcpu=cortex-a8 -mfpu=neon -mfloat-abi=hard" ;;
  *) usage ;;
esac

# Library packages are listed explicitly with their -dev packages: `apt-get download` does not
# follow dependencies. libtomlplusplus-dev is only for its headers (used header-only).
PACKAGES=(libcpputest-dev libpng-dev libpng16-16 zlib1g-dev zlib1g liblzf-dev liblzf1 libtomlplusplus-dev
  # pose link: the nanopb runtime (static library; the generator runs on the host)
  libnanopb-dev)
# HAL device backends: libgpiod (static), libusb (static, needs the shared libudev at run
# time), OpenNI2 (shared only, with its drivers incl. the Dummy test device). The ARM HAL tests
# find the shared ones through LD_LIBRARY_PATH=<sysroot>/usr/lib/<triplet> (tests/CMakeLists.txt).
PACKAGES+=(libgpiod-dev libgpiod2 libusb-1.0-0-dev libusb-1.0-0 libudev1 libopenni2-dev libopenni2-0 libjpeg62-turbo)
# Bump when the layout produced below changes, so that old sysroots are rebuilt.
LAYOUT=2
stamp_text="edgefuse sysroot layout=$LAYOUT arch=$arch packages=${PACKAGES[*]}"

mkdir -p "$dest"
dest=$(cd "$dest" && pwd)
stamp="$dest/.edgefuse-sysroot-stamp"
if [[ -f "$stamp" && "$(cat "$stamp")" == "$stamp_text" ]]; then
  echo "sysroot: $arch up to date in $dest"
  exit 0
fi

# The directory is emptied before unpacking: refuse one that is not ours (a mistyped argument).
if [[ ! -f "$stamp" && -n "$(ls -A "$dest")" ]]; then
  echo "sysroot: $dest is not empty and has no sysroot stamp; refusing to empty it" >&2
  exit 1
fi

SUDO=()
if ((EUID != 0)); then SUDO=(sudo); fi
export DEBIAN_FRONTEND=noninteractive

# Multiarch: apt only knows <arch> packages once the architecture is added and the lists fetched.
if ! dpkg --print-foreign-architectures | grep -qx "$arch"; then
  echo "sysroot: dpkg --add-architecture $arch"
  "${SUDO[@]}" dpkg --add-architecture "$arch"
fi
pkg_specs=()
for p in "${PACKAGES[@]}"; do pkg_specs+=("$p:$arch"); done
lists_have_all() {
  local s
  for s in "${pkg_specs[@]}"; do
    apt-cache show --no-all-versions "$s" >/dev/null 2>&1 || return 1
  done
}
if ! lists_have_all; then
  echo "sysroot: apt-get update (no $arch package lists yet)"
  # Other (non-Debian) sources may fail for a foreign architecture; what matters is checked next.
  "${SUDO[@]}" apt-get update -qq || echo "sysroot: apt-get update reported errors" >&2
  if ! lists_have_all; then
    # A mirror caught mid-sync serves lists of the wrong size: one retry after a pause.
    sleep 20
    "${SUDO[@]}" apt-get update -qq || echo "sysroot: apt-get update reported errors" >&2
    lists_have_all || { echo "sysroot: apt cannot find all of: ${pkg_specs[*]}" >&2; exit 1; }
  fi
fi

debs=$(mktemp -d)
trap 'rm -rf "$debs"' EXIT
(
  cd "$debs"
  apt_opts=(-qq)
  # As root apt would drop to the _apt user, which cannot write here: stay root, without the warning.
  if ((EUID == 0)); then apt_opts+=(-o APT::Sandbox::User=root); fi
  if ! apt-get "${apt_opts[@]}" download "${pkg_specs[@]}"; then
    # Stale lists name versions the mirror no longer has: refresh them once.
    echo "sysroot: download failed; apt-get update and retry"
    "${SUDO[@]}" apt-get update -qq || echo "sysroot: apt-get update reported errors" >&2
    rm -f ./*.deb
    apt-get "${apt_opts[@]}" download "${pkg_specs[@]}"
  fi
)

# Unpack afresh so that files of packages that left the list do not linger.
find "$dest" -mindepth 1 -maxdepth 1 -exec rm -rf {} +
for deb in "$debs"/*.deb; do
  echo "sysroot: unpack $(basename "$deb")"
  dpkg -x "$deb" "$dest"
done
rm -rf "$dest/usr/share/doc" "$dest/usr/share/man"

# Absolute symlinks (e.g. lib/x.so -> /lib/...) would point into the host: make them relative.
while IFS= read -r -d '' link; do
  target=$(readlink "$link")
  if [[ "$target" == /* ]]; then
    ln -sfn "$(realpath -m --relative-to="$(dirname "$link")" "$dest$target")" "$link"
  fi
done < <(find "$dest" -type l -print0)

# liblzf-dev ships only the shared library (and its sources): build the static archive that the
# ARM builds link, so that the test binaries need nothing beyond libc/libstdc++ under qemu.
libdir="$dest/usr/lib/$triplet"
src="$dest/usr/src/liblzf"
if [[ ! -f "$libdir/liblzf.a" && -f "$src/lzf_c.c" ]]; then
  echo "sysroot: build liblzf.a from $src"
  obj=$(mktemp -d)
  for c in lzf_c lzf_d; do
    # shellcheck disable=SC2086  # cflags is a list of flags
    "$triplet-gcc" $cflags -O2 -fPIC -I"$dest/usr/include/liblzf" -c "$src/$c.c" -o "$obj/$c.o"
  done
  "$triplet-ar" rcs "$libdir/liblzf.a" "$obj/lzf_c.o" "$obj/lzf_d.o"
  rm -rf "$obj"
fi

echo "$stamp_text" > "$stamp"
echo "sysroot: $arch ready in $dest"
