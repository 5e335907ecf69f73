#!/usr/bin/env bash
# The Blender version matrix: build and run the project's tests against each
# Debian release's Blender, each release in its own Debian root (debootstrap),
# then build the zip users download and install it in every Blender.
#
#   bash tools/version_matrix.sh                  # host + trixie + sid + dist, every test (as root)
#   bash tools/version_matrix.sh sid              # one root
#   bash tools/version_matrix.sh --blender-only host sid dist
#                                                         # what CI runs: the Blender suites only in the roots
#   bash tools/version_matrix.sh --provision-only sid
#                                                         # make the root and install its packages, no build
#
#   target   Debian        Blender  Python
#   host     this machine  (12 bookworm: 3.4.1, Python 3.11): `bash setup.sh test` in build/
#   trixie   13            4.3.2    3.13
#   sid      unstable      5.2.x    3.14
#   dist     tools/build_dist.sh: one zip with a module for the host's and each root's Python, built in a
#            Debian 11 root (old glibc); then extension_lifecycle.py installs, poses and uninstalls that zip
#            in the host's Blender and in each root's
#
# Roots live in $ARAP_ROOTS/<target> (default /var/tmp/arap-roots) and are
# reused when present (delete one to start afresh). Inside a root the checkout
# is mounted read-only at /srv/<checkout folder name> and built in
# /arap-build/<target>-<checkout folder name> (inside the root), so the checkout
# is never written and two checkouts can use one root at the same time; the
# root's own packages are installed by the same `bash setup.sh` a user runs.
# The run ends with a table (target, Blender, Python, tests passed, minutes),
# also written to $ARAP_MATRIX_REPORT (default build/version_matrix.md).
# Needs root (debootstrap, mount, chroot) for every target but host.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
checkout=$(basename "$here")
# shellcheck source=debian_roots.sh
source "$here/tools/debian_roots.sh"
roots=${ARAP_ROOTS:-/var/tmp/arap-roots}
report=${ARAP_MATRIX_REPORT:-$here/build/version_matrix.md}
mode=test

targets=()
for arg in "$@"; do
  case "$arg" in
    --blender-only) mode=test-blender ;;
    --provision-only) mode=deps ;;
    host|trixie|sid|dist) targets+=("$arg") ;;
    -h|--help) sed -n '2,29p' "$0"; exit 0 ;;
    *) echo "unknown argument '$arg' (targets: host, trixie, sid, dist; --blender-only, --provision-only)" >&2
       exit 2 ;;
  esac
done
[ ${#targets[@]} -gt 0 ] || targets=(host trixie sid dist)
for t in "${targets[@]}"; do
  if [ "$t" != host ] && [ "$(id -u)" -ne 0 ]; then
    echo "the Debian roots need root (debootstrap, mount, chroot): run this as root" >&2
    exit 2
  fi
done
trap unmount_root EXIT
trap 'unmount_root; exit 130' INT TERM

# The roots this run uses (the dist zip carries their Pythons); all present ones when none is named.
dist_roots=()
for t in "${targets[@]}"; do
  case "$t" in trixie|sid) dist_roots+=("$roots/$t") ;; esac
done
if [ ${#dist_roots[@]} -eq 0 ]; then
  for t in trixie sid; do [ -f "$roots/$t/usr/bin/blender" ] && dist_roots+=("$roots/$t"); done
fi

run_dist() {  # build the zip, then its life cycle in every Blender of this run
  bash "$here/tools/build_dist.sh" "${dist_roots[@]}" || return 1
  local zip status=0 version
  version=$(sed -n 's/^version = "\(.*\)"$/\1/p' "$here/addon/arap_deform/blender_manifest.toml")
  zip=build/dist/arap_deform-$version-linux-x64.zip
  if command -v blender >/dev/null; then
    echo "== the dist zip in the host's Blender"
    python3 "$here/blender_tests/extension_lifecycle.py" --blender blender --zip "$here/$zip" \
      --scratch "$here/build/dist/lifecycle-host" || status=1
  fi
  local root
  for root in "${dist_roots[@]}"; do
    echo "== the dist zip in $(basename "$root")'s Blender"
    root_run "$root" "$here" python3 "/srv/$checkout/blender_tests/extension_lifecycle.py" --blender blender \
      --zip "/srv/$checkout/$zip" --scratch "/arap-build/dist-lifecycle-$checkout" || status=1
  done
  return $status
}

declare -A summary
mkdir -p "$(dirname "$report")"
overall=0
for target in "${targets[@]}"; do
  start=$(date +%s)
  log=$(mktemp)
  status=0
  case "$target" in
    host) (cd "$here" && bash setup.sh "$mode") 2>&1 | tee "$log" || status=1 ;;
    dist) [ "$mode" = deps ] || run_dist 2>&1 | tee "$log" || status=1 ;;
    *)
      root=$roots/$target
      { make_root "$target" "$root" &&
        root_run "$root" "$here" ARAP_BUILD_DIR="/arap-build/$target-$checkout" bash "/srv/$checkout/setup.sh" "$mode"
      } 2>&1 | tee "$log" || status=1
      ;;
  esac
  minutes=$(awk -v s="$start" -v e="$(date +%s)" 'BEGIN { printf "%.1f", (e - s) / 60 }')
  tests=$(grep -Eo '[0-9]+% tests passed, [0-9]+ tests failed out of [0-9]+' "$log" | tail -1 || true)
  blender=$(grep -Eo 'Blender [0-9]+\.[0-9]+\.[0-9]+, Python [0-9.]+' "$log" | tail -1 || true)
  if [ "$target" = dist ]; then
    blender="modules: $(grep -Eo 'cpython-[0-9]+' "$log" | sort -u | tr '\n' ' ')"
    tests="life cycle in $(grep -c '^LIFECYCLE OK' "$log" || true) Blender(s), $(grep -c '^LIFECYCLE FAILED' "$log" || true) failed"
  fi
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
