#!/usr/bin/env bash
# Everything a lent hardware GPU needs from this machine, in one command. A device machine
# is held for minutes, cannot reach crates.io or Debian's mirrors, and may lack the Vulkan
# loader; a checkout here may be new (no target/). So this builds and packs, here:
#
#   scripts/device_prepare.sh [A]        # A: a commit to compare with (scripts/device_ab.sh)
#
# - .gl/*.deb             the Vulkan and EGL loaders (downloaded once; ignored by git), as
#                         the device tool's notes say;
# - target/devcarry/      the GPU test binaries and this checkout's `lumen`
#                         (`scripts/device_tests.sh pack`);
# - target/devab/lumen-b  this checkout's `lumen`, stripped (also what
#                         `scripts/device_check.sh` measures: LUMEN_BIN);
# - target/devab/lumen-a  commit A's `lumen`, built in a temporary worktree (only with A).
#
# It ends by printing the device calls to make, which carry target/devcarry, target/devab
# and .gl (about 50 MiB of the 64 allowed). A is built in target/devab-a (the first time
# with all its dependencies: minutes).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
a=${1:-}

if ! ls .gl/libvulkan1_*.deb > /dev/null 2>&1; then
    echo "--- the loaders (.gl)"
    lists=$(mktemp -d)
    mkdir -p .gl "$lists/partial"
    o=(-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 "-oDir::State::Lists=$lists")
    apt-get "${o[@]}" update -qq
    (cd .gl && apt-get "${o[@]}" download libvulkan1 libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2)
    rm -rf "$lists"
fi

mkdir -p target/devab
if [ -n "$a" ]; then
    echo "--- lumen at $a (target/devab/lumen-a)"
    parent=$(mktemp -d)
    tree=$parent/lumen-a
    git worktree add -q --detach "$tree" "$a"
    trap 'git worktree remove --force "$tree"; rm -rf "$parent"' EXIT
    # Its own target folder: in a shared one, cargo would leave target/release/lumen as the
    # last build that linked it, not as the checkout built last (a fresh build relinks
    # nothing). Kept for the next run.
    (cd "$tree" && CARGO_TARGET_DIR="$root/target/devab-a" cargo build --release --bin lumen)
    strip -o target/devab/lumen-a target/devab-a/release/lumen
fi

echo "--- this checkout ($(git rev-parse --short HEAD)): tests and lumen"
scripts/device_tests.sh pack > /dev/null
cargo build --release --bin lumen
strip -o target/devab/lumen-b target/release/lumen

du -sh .gl target/devcarry target/devab
carry='["target/devcarry","target/devab",".gl"]'
setup='for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig;'
cat <<EOF

Device calls, most wanted first (carry $carry; one script per call, since a call returns
at most eight files; the session's device time includes the machine's start):
  $setup LUMEN_BIN=target/devab/lumen-b BUDGET=300 scripts/device_check.sh "\$OUT"
  $setup BUDGET=200 scripts/device_tests.sh run "\$OUT"
EOF
if [ -n "$a" ]; then
    echo "  $setup ROUNDS=2 scripts/device_ab.sh \"\$OUT\""
fi
