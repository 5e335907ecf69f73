#!/usr/bin/env bash
# The Blender version matrix: build and run the project's tests against each
# Debian release's Blender, each release in its own Debian root (debootstrap).
#
#   bash blender_tests/version_matrix.sh                  # host + trixie + sid, every test (as root)
#   bash blender_tests/version_matrix.sh sid              # one root
#   bash blender_tests/version_matrix.sh --blender-only sid
#                                                         # only what the Blender suites need (CI)
#   bash blender_tests/version_matrix.sh --provision-only sid
#                                                         # make the root and install its packages, no build
#
#   target   Debian        Blender  Python
#   host     this machine  (12 bookworm: 3.4.1, Python 3.11), `bash setup.sh test` in build/
#   trixie   13            4.3.2    3.13
#   sid      unstable      5.2.x    3.14
#
# Roots live in $ARAP_ROOTS/<target> (default /var/tmp/arap-roots) and are
# reused when present (delete one to start afresh). Inside a root the checkout
# is mounted read-only at /srv/<checkout folder name> and built in
# /arap-build/<target>-<checkout folder name> (inside the root), so the checkout
# is never written and two checkouts can use one root at the same time; the
# root's own packages are installed by the same `bash setup.sh` a user runs.
# The run ends with a table (target, Blender, Python, tests passed, minutes), also written to
# $ARAP_MATRIX_REPORT (default build/version_matrix.md). Needs root (debootstrap,
# mount, chroot) for every target but host.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
checkout=$(basename "$here")
roots=${ARAP_ROOTS:-/var/tmp/arap-roots}
mirror=${ARAP_DEBIAN_MIRROR:-http://deb.debian.org/debian}
report=${ARAP_MATRIX_REPORT:-$here/build/version_matrix.md}
mode=test

targets=()
for arg in "$@"; do
  case "$arg" in
    --blender-only) mode=test-blender ;;
    --provision-only) mode=deps ;;
    host|trixie|sid) targets+=("$arg") ;;
    -h|--help) sed -n '2,26p' "$0"; exit 0 ;;
    *) echo "unknown argument '$arg' (targets: host, trixie, sid; --blender-only, --provision-only)" >&2; exit 2 ;;
  esac
done
[ ${#targets[@]} -gt 0 ] || targets=(host trixie sid)
for t in "${targets[@]}"; do
  if [ "$t" != host ] && [ "$(id -u)" -ne 0 ]; then
    echo "the Debian roots need root (debootstrap, mount, chroot): run this as root" >&2
    exit 2
  fi
done

mounted=()
unmount_all() {
  local i
  for ((i = ${#mounted[@]} - 1; i >= 0; i--)); do
    umount "${mounted[i]}" 2>/dev/null || umount -l "${mounted[i]}" 2>/dev/null || true
  done
  mounted=()
}
trap unmount_all EXIT
trap 'unmount_all; exit 130' INT TERM

mount_into() {  # mount_into <root> <source> <mount point inside the root> [mount options...]
  local root=$1 what=$2 where=$3
  shift 3
  mkdir -p "$root$where"
  mount "$@" "$what" "$root$where"
  mounted+=("$root$where")
}

make_root() {  # make_root <suite> <root>: a minimal Debian, once
  local suite=$1 root=$2
  if [ -f "$root/.arap-root-ready" ]; then
    echo "== reusing the $suite root in $root"
    return 0
  fi
  command -v debootstrap >/dev/null || DEBIAN_FRONTEND=noninteractive apt-get install -y -qq debootstrap
  echo "== debootstrap --variant=minbase $suite $root"
  rm -rf "$root"
  mkdir -p "$root"
  if ! debootstrap --variant=minbase "$suite" "$root" "$mirror" > "$root.debootstrap.log" 2>&1; then
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

in_root() {  # in_root <target> <root> <setup.sh mode>: the user's setup.sh, inside the root
  local target=$1 root=$2 setup_mode=$3 status=0
  # This runs in a subshell (the caller pipes it to tee): unmount on its own exit.
  trap unmount_all EXIT
  trap 'unmount_all; exit 130' INT TERM
  cp /etc/resolv.conf "$root/etc/resolv.conf"
  mount_into "$root" proc /proc -t proc
  mount_into "$root" sysfs /sys -t sysfs
  mount_into "$root" /dev /dev --bind
  mount_into "$root" /dev/pts /dev/pts --bind
  [ -d /dev/shm ] && mount_into "$root" /dev/shm /dev/shm --bind
  local src=/srv/$checkout
  mount_into "$root" "$here" "$src" --bind
  mount -o remount,bind,ro "$root$src"
  chroot "$root" /usr/bin/env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin HOME=/root LANG=C.UTF-8 \
    ARAP_BUILD_DIR="/arap-build/$target-$checkout" bash "$src/setup.sh" "$setup_mode" || status=$?
  unmount_all
  return $status
}

declare -A summary
mkdir -p "$(dirname "$report")"
overall=0
for target in "${targets[@]}"; do
  start=$(date +%s)
  log=$(mktemp)
  status=0
  if [ "$target" = host ]; then
    (cd "$here" && bash setup.sh "$mode") 2>&1 | tee "$log" || status=1
  else
    root=$roots/$target
    { make_root "$target" "$root" && in_root "$target" "$root" "$mode"; } 2>&1 | tee "$log" || status=1
  fi
  minutes=$(awk -v s="$start" -v e="$(date +%s)" 'BEGIN { printf "%.1f", (e - s) / 60 }')
  tests=$(grep -Eo '[0-9]+% tests passed, [0-9]+ tests failed out of [0-9]+' "$log" | tail -1 || true)
  blender=$(grep -Eo 'Blender [0-9]+\.[0-9]+\.[0-9]+, Python [0-9.]+' "$log" | tail -1 || true)
  [ "$mode" = deps ] && tests="(provisioned only)"
  summary[$target]="| $target | ${blender:-?} | ${tests:-no test ran} | $minutes | $([ $status = 0 ] && echo pass || echo FAIL) |"
  rm -f "$log"
  [ $status = 0 ] || overall=1
done

{
  echo "| target | Blender, Python | tests | minutes | result |"
  echo "|---|---|---|---|---|"
  for target in "${targets[@]}"; do echo "${summary[$target]}"; done
} | tee "$report"
exit $overall
