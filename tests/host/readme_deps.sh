#!/bin/sh
# The README's dependency table stays true (issue 22): every library the build looks up with
# pkg-config (pkg_check_modules in any CMakeLists.txt or *.cmake) has a row naming its Debian
# package, and every row whose package ships a pkg-config module is used by the build: through
# pkg_check_modules, or through find_library naming one of its libraries (OpenSSL, Mbed TLS).
# Packages are found with dpkg; a module that is not installed cannot be mapped and is reported.
# usage: readme_deps.sh SOURCE_DIR [README]
set -u
src=$1 readme=${2:-$1/README.md}
fail=0
cmake_files=$(find "$src" -path "$src/build*" -prune -o \( -name CMakeLists.txt -o -name '*.cmake' \) -print)
# Calls joined onto one line each (a call may span lines), comments dropped.
calls=$(cat $cmake_files | sed 's/#.*//' | tr '\n' ' ' | sed 's/)/)\n/g')
modules=$(printf '%s\n' "$calls" | sed -n 's/.*pkg_check_modules(\([^)]*\)).*/\1/p' |
    awk '{for (i = 2; i <= NF; i++) if ($i !~ /^(REQUIRED|QUIET|IMPORTED_TARGET|GLOBAL|NO_CMAKE_PATH|NO_CMAKE_ENVIRONMENT_PATH)$/) print $i}' |
    sed 's/[<>=].*//' | sort -u)
libraries=$(printf '%s\n' "$calls" | sed -n 's/.*find_library(\([^)]*\)).*/\1/p' |
    awk '{for (i = 2; i <= NF; i++) if ($i !~ /^(NAMES|REQUIRED|PATHS|HINTS|NO_DEFAULT_PATH)$/ && $i !~ /[\/$]/) print $i}' | sort -u)
# The table: the rows of the section headed "## Dependencies", up to the next heading.
rows=$(awk '/^## / { in_deps = /^## Dependencies/; next } in_deps && /^\| `/' "$readme")
packages=$(printf '%s\n' "$rows" | cut -d'|' -f2 | grep -o '`[^`]*`' | tr -d '`' | sort -u)
[ -n "$packages" ] || { echo "FAIL: no dependency table in $readme"; exit 1; }

package_of_module() {
    dir=$(pkg-config --variable=pcfiledir "$1" 2>/dev/null) || return 1
    dpkg -S "$dir/$1.pc" 2>/dev/null | head -1 | cut -d: -f1
}

for m in $modules; do
    pkg=$(package_of_module "$m")
    if [ -z "$pkg" ]; then
        echo "note: pkg-config module $m is not installed here: its README row cannot be checked"
        continue
    fi
    if printf '%s\n' "$packages" | grep -qx "$pkg"; then
        echo "ok: pkg-config $m -> $pkg, in the table"
    else
        echo "FAIL: the build looks up $m with pkg-config (package $pkg); the README's dependency table has no row for $pkg"
        fail=1
    fi
done

for pkg in $packages; do
    # Libraries' modules only: /usr/share/pkgconfig holds data-only ones (systemd's unit folders).
    pcs=$(dpkg -L "$pkg" 2>/dev/null | grep -v '^/usr/share/pkgconfig/' | sed -n 's|.*/pkgconfig/\(.*\)\.pc$|\1|p')
    [ -n "$pcs" ] || continue # a tool, not a library found with pkg-config
    used=
    for pc in $pcs; do
        printf '%s\n' "$modules" | grep -qx "$pc" && used="pkg-config $pc"
    done
    for lib in $(dpkg -L "$pkg" | sed -n 's|.*/lib\([^/]*\)\.so$|\1|p'); do
        printf '%s\n' "$libraries" | grep -qx "$lib" && used="find_library $lib"
    done
    if [ -n "$used" ]; then
        echo "ok: row $pkg: the build uses it ($used)"
    else
        echo "FAIL: the README's dependency table names $pkg (pkg-config: $(echo $pcs)), which the build no longer looks up"
        fail=1
    fi
done
[ $fail = 0 ] && echo "readme dependencies: ok"
exit $fail
