#!/usr/bin/env bash
# The Python package's tests on a fresh machine: a new venv, maturin, numpy,
# pytest, emva1288 (the EMVA reference analysis), astropy, tqdm (progress
# bars) and nbclient/nbformat/ipykernel (python/examples/quickstart.ipynb
# runs in a Jupyter kernel) from PyPI, the wheel built from this checkout,
# then pytest (python/tests; the bit-identity tests run the `gloam` CLI
# built here).
#
# The wheel is built with Cargo's dev profile in the workspace's target
# directory, so after `cargo test --workspace` (CI) only the extension
# module itself is compiled (its dependencies are optimised: see
# [profile.dev.package."*"] in Cargo.toml). `bash python/test.sh --release`
# builds an optimised wheel instead.
#
# `bash python/test.sh --venv-only DIR` makes the venv with its PyPI
# packages in DIR and stops; `GLOAM_PY_VENV=DIR bash python/test.sh` then
# uses it (CI fetches the packages while clippy runs: network, not CPU).
set -euo pipefail
cd "$(dirname "$0")/.."
# The venv and its PyPI packages, in directory $1.
make_venv() {
    python3 -m venv "$1"
    # astropy: test_frame_files.py reads the FITS frames with it (a wheel, no build).
    "$1/bin/python" -m pip install -q --disable-pip-version-check --only-binary astropy,pyzmq \
        maturin numpy pytest emva1288 astropy tqdm nbclient nbformat ipykernel
}
if [ "${1:-}" = --venv-only ]; then
    make_venv "${2:?--venv-only DIR}"
    exit 0
fi
profile=dev
[ "${1:-}" = --release ] && profile=release
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$PWD/target}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
venv="${GLOAM_PY_VENV:-}"
if [ -z "$venv" ] || [ ! -x "$venv/bin/python" ]; then
    venv="$work/venv"
    make_venv "$venv"
fi
py="$venv/bin/python"
t0=$(date +%s)
bindir=debug
[ "$profile" = release ] && bindir=release
# The CLI the bit-identity tests compare against: GLOAM_BIN when the caller
# already built it (CI: `cargo test --workspace` leaves target/debug/gloam,
# with the tests' features; building it again here would resolve different
# features and compile a second set of the workspace), else built here.
if [ -z "${GLOAM_BIN:-}" ] || [ ! -x "$GLOAM_BIN" ]; then
    cargo build -q --bin gloam --profile "$profile"
    GLOAM_BIN="$CARGO_TARGET_DIR/$bindir/gloam"
fi
"$venv/bin/maturin" build -q --profile "$profile" -m python/Cargo.toml --out "$work/wheels"
"$py" -m pip install -q --disable-pip-version-check "$work"/wheels/gloam-*.whl
echo "python/test.sh: CLI and wheel built in $(( $(date +%s) - t0 )) s ($profile profile)"
cd "$work"
GLOAM_BIN="$GLOAM_BIN" "$py" -m pytest -q -p no:cacheprovider "$OLDPWD/python/tests"
