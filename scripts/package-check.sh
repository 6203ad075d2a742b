#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The installed package as a user gets it (docs/cpp.md; ctest `package_install`, label `package`):
#   1. `cmake --install` into a temporary prefix; the files, the SONAME, and the shared library's
#      exported interface naming no private dependency (GDAL, OpenImageIO, ...);
#   2. examples/cpp configured with find_package(terracl 0.1), built and RUN against the shared
#      library, then against the static one (COMPONENTS static); the installed CLI reads the result;
#   3. `cpack -G DEB`, the packages' contents (`dpkg-deb -c`), Depends (dpkg-shlibdeps) and lintian.
# usage: scripts/package-check.sh [BUILD_DIR] [DEM]   (a complete build: `cmake --build BUILD_DIR`)
set -euo pipefail
src=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "${1:-$src/build}" && pwd)
dem=${2:-$src/data/crops/presidential_128x96.tif}
work=$(mktemp -d "${TMPDIR:-/tmp}/terracl-package.XXXXXX")
trap 'rm -rf "$work"' EXIT
fail() { echo "package-check: FAIL: $*" >&2; exit 1; }
t0=$(date +%s%N)
lap() { local t; t=$(date +%s%N); echo "package-check: $1 $(( (t - t0) / 1000000 )) ms"; t0=$t; }

# 1. install
prefix=$work/prefix
cmake --install "$build" --prefix "$prefix" >/dev/null
libdir=
for d in lib/x86_64-linux-gnu lib64 lib; do
  if [ -e "$prefix/$d/libterracl.a" ]; then libdir=$d; break; fi
done
[ -n "$libdir" ] || fail "no libterracl.a under $prefix/lib*"
# Debian policy: libraries in the multiarch folder (what docs/cpp.md names).
if [ -e /etc/debian_version ] && command -v dpkg-architecture >/dev/null 2>&1; then
  ma=$(dpkg-architecture -qDEB_HOST_MULTIARCH)
  [ "$libdir" = "lib/$ma" ] || fail "libraries installed in $libdir, not Debian's multiarch lib/$ma"
fi
version=$(sed -n 's/^#define TERRACL_VERSION "\(.*\)"$/\1/p' "$prefix/include/terracl/version.hpp")
for f in bin/terracl "$libdir/libterracl.a" "$libdir/libterracl.so" "$libdir/libterracl.so.0" \
         "$libdir/libterracl.so.$version" include/terracl/reconstruct.hpp include/terracl/version.hpp \
         "$libdir/cmake/terracl/terraclConfig.cmake" "$libdir/cmake/terracl/terraclConfigVersion.cmake" \
         "$libdir/cmake/terracl/terraclTargets.cmake"; do
  [ -e "$prefix/$f" ] || fail "not installed: $f"
done
[ "$(find "$prefix/include" -name '*.hpp' | wc -l)" = "$(( $(ls "$src"/host/include/terracl/*.hpp | wc -l) + 1 ))" ] ||
  fail "installed headers differ from host/include/terracl + version.hpp"
soname=$(readelf -d "$prefix/$libdir/libterracl.so.$version" | sed -n 's/.*SONAME.*\[\(.*\)\]/\1/p')
[ "$soname" = libterracl.so.0 ] || fail "SONAME is '$soname', expected libterracl.so.0"
# The shared library's INTERFACE_LINK_LIBRARIES: public dependencies only.
shared_iface=$(sed -n '/^set_target_properties(terracl::terracl_shared/,/^)/p' "$prefix/$libdir/cmake/terracl/terraclTargets.cmake")
[ -n "$shared_iface" ] || fail "terracl::terracl_shared not exported"
if grep -Eqi 'gdal|openimageio|openexr|flann|tinygltf|lz4|httplib' <<<"$shared_iface"; then
  fail "private dependency in terracl::terracl_shared's interface: $shared_iface"
fi
lap "install"

# 2. the example against the installed package, shared then static
launcher=()
if command -v ccache >/dev/null 2>&1; then launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi
for kind in shared static; do
  ex=$work/example-$kind
  static=OFF; [ $kind = static ] && static=ON
  cmake -S "$src/examples/cpp" -B "$ex" -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$prefix" \
        -DTERRACL_EXAMPLE_STATIC=$static "${launcher[@]}" >"$work/configure-$kind.log" 2>&1 ||
    { cat "$work/configure-$kind.log"; fail "examples/cpp does not configure against the installed package ($kind)"; }
  cmake --build "$ex" -j "${JOBS:-2}" >"$work/build-$kind.log" 2>&1 ||
    { cat "$work/build-$kind.log"; fail "examples/cpp does not build ($kind)"; }
  needed=$(readelf -d "$ex/terracl_example" | grep NEEDED || true)
  if [ $kind = shared ]; then
    grep -q 'libterracl.so.0' <<<"$needed" || fail "shared example does not load libterracl.so.0"
  else
    ! grep -q 'libterracl' <<<"$needed" || fail "static example loads libterracl.so"
  fi
  mkdir -p "$work/out-$kind"
  "$ex/terracl_example" "$dem" "$work/out-$kind/eroded.tif" 50 || fail "examples/cpp ($kind) failed"
  "$prefix/bin/terracl" info "$work/out-$kind/eroded.tif" >/dev/null || fail "installed CLI cannot read the result"
  lap "example ($kind)"
done
# Same objects, same device: the same bits.
cmp -s "$work/out-shared/eroded.tif" "$work/out-static/eroded.tif" || fail "shared and static examples disagree"
# A version the package does not accept (SameMinorVersion) is refused.
mkdir -p "$work/v02" && printf 'cmake_minimum_required(VERSION 3.16)\nproject(v LANGUAGES NONE)\nfind_package(terracl 0.2 REQUIRED)\n' >"$work/v02/CMakeLists.txt"
if cmake -S "$work/v02" -B "$work/v02/b" -DCMAKE_PREFIX_PATH="$prefix" >/dev/null 2>&1; then
  fail "find_package(terracl 0.2) accepted $version"
fi

# 3. Debian packages
(cd "$build" && cpack -G DEB -B "$work/deb" >"$work/cpack.log" 2>&1) || { cat "$work/cpack.log"; fail "cpack -G DEB"; }
lap "cpack"
deb() { local f; for f in "$work"/deb/"$1"_*.deb; do [ -e "$f" ] && echo "$f"; done; return 0; }
rt=$(deb terracl); dev=$(deb terracl-dev)
[ -n "$rt" ] && [ -n "$dev" ] || fail "cpack made $(ls "$work"/deb/*.deb 2>/dev/null | xargs -n1 basename | tr '\n' ' ')"
contents() { dpkg-deb -c "$1" | awk '{print $6}'; }
for f in ./usr/bin/terracl "./usr/$libdir/libterracl.so.$version" "./usr/$libdir/libterracl.so.0" \
         ./usr/share/man/man1/terracl.1.gz ./usr/share/bash-completion/completions/terracl; do
  contents "$rt" | grep -qx "$f" || fail "$(basename "$rt") lacks $f"
done
for f in ./usr/include/terracl/reconstruct.hpp ./usr/include/terracl/version.hpp "./usr/$libdir/libterracl.a" \
         "./usr/$libdir/libterracl.so" "./usr/$libdir/cmake/terracl/terraclConfig.cmake"; do
  contents "$dev" | grep -qx "$f" || fail "$(basename "$dev") lacks $f"
done
! contents "$rt" | grep -q '/include/' || fail "$(basename "$rt") ships headers"
# The licence in every package (Debian policy: /usr/share/doc/<package>/copyright).
for p in "$work"/deb/*.deb; do
  name=$(dpkg-deb -f "$p" Package)
  contents "$p" | grep -qx "./usr/share/doc/$name/copyright" || fail "$(basename "$p") lacks /usr/share/doc/$name/copyright"
done
depends=$(dpkg-deb -f "$rt" Depends)
grep -q 'libgdal' <<<"$depends" && grep -q 'libpng16' <<<"$depends" ||
  fail "$(basename "$rt") Depends not computed by dpkg-shlibdeps: '$depends'"
grep -q "terracl (= $version)" <<<"$(dpkg-deb -f "$dev" Depends)" || fail "terracl-dev does not depend on terracl"
py=$(deb python3-terracl)
# The Python module is built whenever pybind11 is found; then its package must exist and carry it.
if ls "$build"/python/terracl/_terracl*.so >/dev/null 2>&1; then
  [ -n "$py" ] || fail "the Python module is built but cpack made no python3-terracl package"
  contents "$py" | grep -q '/terracl/_terracl.*\.so$' || fail "$(basename "$py") lacks the module"
  contents "$py" | grep -q '/terracl/__init__\.py$' || fail "$(basename "$py") lacks terracl/__init__.py"
fi
if [ -n "$py" ]; then echo "package-check: $(basename "$py"): $(contents "$py" | grep -c '\.so$') module file(s)"; fi
# Debian policy as lintian checks it: no errors. (Its warnings are printed: the ldconfig calls
# CPack writes, and the library not being in its own libterracl0 package.)
if command -v lintian >/dev/null 2>&1; then
  lintian --tag-display-limit 0 "$work"/deb/*.deb >"$work/lintian.log" 2>&1 || true
  grep -v '^running with root' "$work/lintian.log" | sed 's/^/package-check: lintian: /'
  ! grep -q '^E: ' "$work/lintian.log" || fail "lintian reports errors on the packages"
  lap "lintian"
elif [ "${CI:-}" = true ]; then
  fail "lintian is not installed (scripts/install-deps.sh installs it)"
fi
for p in "$work"/deb/*.deb; do echo "package-check: $(basename "$p") $(du -k "$p" | cut -f1) KiB"; done
echo "package-check: OK (terracl $version)"
