#!/usr/bin/env bash
# The add-on zip for users of any Blender on Linux x86-64: one native module per
# Python ABI inside (Python picks the one whose tag matches its own), so the same
# zip loads in blender.org's 4.2/4.5/5.0 (Python 3.11), 5.1/5.2 (Python 3.13) and
# the Blenders of Debian 12 (3.11), 13 (3.13) and unstable (3.14).
#
#   bash tools/build_dist.sh [ROOT...]      as root; ROOTs are Debian roots of the version matrix
#
# The module is built for the host's Python (when its headers are installed) and
# for the Python of every ROOT that has python3-dev, from their headers, with the
# newest pybind11 found among them. All are compiled in a Debian 11 (bullseye)
# builder root ($ARAP_ROOTS/bullseye, made once) whose old glibc sets the floor:
# with libstdc++ linked in, the modules need only glibc (the version is printed
# and written to build/dist/modules.md), libm and libgcc_s.
# Output: build/dist/arap_deform-<version>-linux-x64.zip, with the folder
# arap_deform/ inside, which Blender 4.2+ installs as an extension (Install from
# Disk, `blender --command extension install-file`) and 3.x as a legacy add-on.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
# shellcheck source=debian_roots.sh
source "$here/tools/debian_roots.sh"
trap unmount_root EXIT
roots=${ARAP_ROOTS:-/var/tmp/arap-roots}
builder=$roots/bullseye
dist=$here/build/dist
headers=$dist/headers
version=$(sed -n 's/^version = "\(.*\)"$/\1/p' "$here/addon/arap_deform/blender_manifest.toml")
[ "$(id -u)" -eq 0 ] || { echo "build_dist.sh needs root (debootstrap, chroot)" >&2; exit 2; }

rm -rf "$dist"
mkdir -p "$headers"

pybind11_version() {  # pybind11_version <include folder>: e.g. 3001 for 3.1, 0 when absent
  local h=$1/pybind11/detail/common.h
  [ -f "$h" ] || { echo 0; return; }
  awk '/#define PYBIND11_VERSION_MAJOR/{a=$3} /#define PYBIND11_VERSION_MINOR/{b=$3} END{print a*1000+b}' "$h"
}

# Python headers: the host's (prefix "") and each root's.
abis=()
best_pybind=0
for prefix in "" "$@"; do
  for inc in "$prefix"/usr/include/python3.[0-9]*; do
    [ -f "$inc/Python.h" ] || continue
    v=${inc##*/python}
    case "$v" in *[!0-9.]*) continue ;; esac   # skip debug/free-threaded variants
    [ -f "$prefix/usr/include/x86_64-linux-gnu/python$v/pyconfig.h" ] || continue
    [ -d "$headers/py$v" ] && continue
    mkdir -p "$headers/py$v/include/x86_64-linux-gnu"
    cp -r "$inc" "$headers/py$v/include/"
    cp -r "$prefix/usr/include/x86_64-linux-gnu/python$v" "$headers/py$v/include/x86_64-linux-gnu/"
    abis+=("$v")
  done
  pv=$(pybind11_version "$prefix/usr/include")
  if [ "$pv" -gt "$best_pybind" ]; then
    best_pybind=$pv
    rm -rf "$headers/pybind11"
    mkdir -p "$headers/pybind11"
    cp -r "$prefix/usr/include/pybind11" "$headers/pybind11/"
  fi
done
[ ${#abis[@]} -gt 0 ] || { echo "no Python headers found (install python3-dev)" >&2; exit 1; }
echo "== Pythons: ${abis[*]}; pybind11 $((best_pybind / 1000)).$((best_pybind % 1000))"

make_root bullseye "$builder"
if [ ! -f "$builder/.arap-builder-ready" ]; then
  root_run "$builder" "$here" bash -c "apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
    --no-install-recommends g++ make cmake libeigen3-dev >/dev/null"
  touch "$builder/.arap-builder-ready"
fi

src=/srv/$(basename "$here")
stage=$dist/stage/arap_deform
mkdir -p "$stage"
(cd "$here"/addon/arap_deform && find . -name __pycache__ -prune -o \( -name '*.py' -o -name blender_manifest.toml \) \
   -print0 | xargs -0 cp --parents -t "$stage/")
{
  echo "| module | built with | needs glibc | links |"
  echo "|---|---|---|---|"
} > "$dist/modules.md"
for v in "${abis[@]}"; do
  tag=cpython-${v/./}-x86_64-linux-gnu
  build=/arap-build/dist-$(basename "$here")  # one build: libarap is compiled once, the module per ABI
  echo "== module for Python $v ($tag)"
  root_run "$builder" "$here" bash -c "rm -f $build/addon/arap_deform/*.so; cmake -S $src -B $build -DCMAKE_BUILD_TYPE=Release -DARAP_BUILD_CLI=OFF \
      -DARAP_BUILD_TESTS=OFF -DARAP_BUILD_BENCH=OFF -DARAP_DIST_PYTHON_SOABI=$tag \
      '-DARAP_DIST_PYTHON_INCLUDE=$src/build/dist/headers/py$v/include/python$v;$src/build/dist/headers/py$v/include' \
      -DARAP_DIST_PYBIND11_INCLUDE=$src/build/dist/headers/pybind11 > /dev/null \
    && cmake --build $build -j$(nproc) --target _arap_native 2>&1 | grep -E 'error:|warning:' || true"
  so=$builder$build/addon/arap_deform/_arap_native.$tag.so
  [ -f "$so" ] || { echo "the module for Python $v did not build" >&2; exit 1; }
  cp "$so" "$stage/"
  glibc=$(objdump -T "$so" | grep -o 'GLIBC_[0-9.]*' | sort -V | tail -1)
  links=$(objdump -p "$so" | awk '/NEEDED/{print $2}' | tr '\n' ' ')
  # The README promises glibc 2.17: a newer symbol (Volume's std::pow once pulled in pow@GLIBC_2.29) fails the build.
  if [ "$(printf '%s\n' GLIBC_2.17 "$glibc" | sort -V | tail -1)" != GLIBC_2.17 ]; then
    echo "the module for Python $v needs $glibc, newer than the 2.17 the README promises:" >&2
    objdump -T "$so" | grep -F "($glibc)" >&2
    exit 1
  fi
  echo "| _arap_native.$tag.so | Debian 11 GCC $(chroot "$builder" gcc -dumpversion), pybind11 $((best_pybind / 1000)).$((best_pybind % 1000)) | ${glibc#GLIBC_} | $links|" >> "$dist/modules.md"
done

zip=$dist/arap_deform-$version-linux-x64.zip
python3 - "$dist/stage" "$zip" <<'EOF'
import os, sys, zipfile
stage, out = sys.argv[1], sys.argv[2]
with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
    for folder, _dirs, files in sorted(os.walk(stage)):
        for name in sorted(files):
            path = os.path.join(folder, name)
            info = zipfile.ZipInfo(os.path.relpath(path, stage), date_time=(2020, 1, 1, 0, 0, 0))
            info.external_attr = (0o755 if name.endswith(".so") else 0o644) << 16
            with open(path, "rb") as f:
                z.writestr(info, f.read(), zipfile.ZIP_DEFLATED)
EOF
cat "$dist/modules.md"
echo "== $zip"
