#!/usr/bin/env bash
# A newer Mesa lavapipe beside the system's, for side-by-side measurements (BENCHMARKS.md
# "Mesa 26.1 lavapipe"). CI and the README use the system's lavapipe (Debian
# bookworm-backports, Mesa 25.0); Debian builds newer Mesa only for newer releases
# (trixie-backports: Mesa 26.1 with LLVM 19), whose libraries need trixie's glibc. So this
# unpacks that lavapipe with the trixie runtime it depends on into a folder (no root, nothing
# installed system-wide) and writes a wrapper that runs a program under trixie's dynamic
# loader with only that driver visible:
#
#   scripts/newer_lavapipe.sh [PREFIX]            # default PREFIX: target/newer-lavapipe
#   target/newer-lavapipe/run target/release/lumen devices
#   target/newer-lavapipe/run target/release/lumen render scenes/cornell.sl --device gpu
#
# SUITE and PACKAGE choose another driver (defaults: trixie-backports, mesa-vulkan-drivers);
# MIRROR another Debian mirror. Needs curl, xz, python3 and dpkg-deb.
set -euo pipefail

prefix=${1:-target/newer-lavapipe}
mirror=${MIRROR:-http://deb.debian.org/debian}
suite=${SUITE:-trixie-backports}
base=${suite%%-*}
package=${PACKAGE:-mesa-vulkan-drivers}
mkdir -p "$prefix/debs" "$prefix/root"
prefix=$(cd "$prefix" && pwd)

for s in "$base" "$suite"; do
    [ -s "$prefix/Packages-$s.xz" ] ||
        curl -fsS -m 300 -o "$prefix/Packages-$s.xz" "$mirror/dists/$s/main/binary-amd64/Packages.xz"
done

# The dependency closure of the driver, the loader and the C/C++ runtime: the suite's own
# packages, the backports suite only for Mesa's (as apt would pick them with -t SUITE).
python3 - "$prefix" "$base" "$suite" "$package" libvulkan1 libc6 libstdc++6 > "$prefix/packages.txt" <<'EOF'
import lzma, re, sys
prefix, base, suite, *wanted = sys.argv[1:]
index = {}
for s in (base, suite):
    for block in lzma.open(f"{prefix}/Packages-{s}.xz", "rt").read().split("\n\n"):
        fields = dict(re.findall(r"^([A-Za-z-]+): (.*)$", block, re.M))
        name = fields.get("Package")
        if name and (s == base or name.startswith("mesa-") or name not in index):
            index[name] = fields
provides = {}
for name, fields in index.items():
    for p in fields.get("Provides", "").split(","):
        if p.strip():
            provides.setdefault(p.strip().split(" ")[0], name)
# Essential tools and data the libraries never load.
skip = {"debconf", "debconf-2.0", "perl-base", "dpkg", "libc-bin", "tzdata"}
seen, todo = [], list(wanted)
while todo:
    name = todo.pop()
    name = name if name in index else provides.get(name, name)
    if name in seen or name in skip:
        continue
    if name not in index:
        sys.exit(f"no package {name} in {suite}")
    seen.append(name)
    for field in ("Depends", "Pre-Depends"):
        for dep in index[name].get(field, "").split(","):
            if dep.strip():
                todo.append(dep.split("|")[0].strip().split(" ")[0].split(":")[0])
for name in seen:
    print(index[name]["Filename"])
EOF

while read -r file; do
    deb="$prefix/debs/$(basename "$file")"
    [ -s "$deb" ] || curl -fsS -m 300 -o "$deb" "$mirror/$file"
    dpkg-deb -x "$deb" "$prefix/root"
done < "$prefix/packages.txt"

lib="$prefix/root/usr/lib/x86_64-linux-gnu"
# The driver manifest names its library by file name; point it at the unpacked one.
sed "s#\"library_path\": \"[^\"]*\"#\"library_path\": \"$lib/libvulkan_lvp.so\"#" \
    "$prefix/root/usr/share/vulkan/icd.d/lvp_icd.json" > "$prefix/lvp_icd.json"
cat > "$prefix/run" <<EOF
#!/bin/sh
# Runs a program under $suite's glibc with its lavapipe as the only Vulkan driver.
exec env VK_DRIVER_FILES="$prefix/lvp_icd.json" VK_ICD_FILENAMES="$prefix/lvp_icd.json" \\
    "$lib/ld-linux-x86-64.so.2" --library-path "$lib" "\$@"
EOF
chmod +x "$prefix/run"
echo "$(wc -l < "$prefix/packages.txt") packages unpacked; run programs with $prefix/run"
