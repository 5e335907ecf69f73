# Debian roots for the version matrix and the distribution build (sourced by
# tools/version_matrix.sh and tools/build_dist.sh; needs root).
#
#   make_root <suite> <folder>             debootstrap --variant=minbase once; reused afterwards
#   root_run <folder> <checkout> <cmd...>  run a command inside, with proc/sys/dev mounted and the
#                                          checkout read-only at /srv/<its folder name>; unmounts after
#
# ARAP_DEBIAN_MIRROR overrides the mirror (default http://deb.debian.org/debian).

arap_root_mounts=()

unmount_root() {
  local i
  for ((i = ${#arap_root_mounts[@]} - 1; i >= 0; i--)); do
    umount "${arap_root_mounts[i]}" 2>/dev/null || umount -l "${arap_root_mounts[i]}" 2>/dev/null || true
  done
  arap_root_mounts=()
}

_mount_into() {  # _mount_into <root> <source> <mount point inside the root> [mount options...]
  local root=$1 what=$2 where=$3
  shift 3
  mkdir -p "$root$where"
  mount "$@" "$what" "$root$where"
  arap_root_mounts+=("$root$where")
}

make_root() {
  local suite=$1 root=$2
  if [ -f "$root/.arap-root-ready" ]; then
    echo "== reusing the $suite root in $root"
    return 0
  fi
  command -v debootstrap >/dev/null || DEBIAN_FRONTEND=noninteractive apt-get install -y -qq debootstrap
  echo "== debootstrap --variant=minbase $suite $root"
  rm -rf "$root"
  mkdir -p "$root"
  if ! debootstrap --variant=minbase "$suite" "$root" "${ARAP_DEBIAN_MIRROR:-http://deb.debian.org/debian}" \
      > "$root.debootstrap.log" 2>&1; then
    tail -20 "$root.debootstrap.log" >&2
    return 1
  fi
  if [ "$suite" = sid ]; then
    # sid's Release files on the mirror are sometimes past their Valid-Until
    # date; accept them inside this root only.
    echo 'Acquire::Check-Valid-Until "false";' > "$root/etc/apt/apt.conf.d/99arap-no-valid-until"
  fi
  touch "$root/.arap-root-ready"
}

root_run() {
  local root=$1 checkout=$2 status=0
  shift 2
  # Callers often run this in a pipeline's subshell, which has no traps of its own.
  trap unmount_root EXIT
  trap 'unmount_root; exit 130' INT TERM
  cp /etc/resolv.conf "$root/etc/resolv.conf"
  _mount_into "$root" proc /proc -t proc
  _mount_into "$root" sysfs /sys -t sysfs
  _mount_into "$root" /dev /dev --bind
  _mount_into "$root" /dev/pts /dev/pts --bind
  [ -d /dev/shm ] && _mount_into "$root" /dev/shm /dev/shm --bind
  local src=/srv/$(basename "$checkout")
  _mount_into "$root" "$checkout" "$src" --bind
  mount -o remount,bind,ro "$root$src"
  chroot "$root" /usr/bin/env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin HOME=/root LANG=C.UTF-8 "$@" || status=$?
  unmount_root
  return $status
}
