#!/usr/bin/env bash
# Reconstruct the path of a bundled recording and print the summary and the plots' paths.
# Usage: scripts/demo.sh [OUTDIR]   (called by `make demo` after the venv exists)
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
OUT="${1:-out/demo}"
BOOTNAV="${BOOTNAV:-$HERE/.venv/bin/bootnav}"
[ -x "$BOOTNAV" ] || BOOTNAV="bootnav"

# Prefer a recording shipped in recordings/ (the x-io closed loop, else any recording with a
# <name>.reference.json); otherwise the x-io NGIMU short closed-loop walk (MIT licence,
# xioTechnologies/Gait-Tracking) from the shared datasets. `bootnav process` never modifies its input (the
# results go to OUTDIR/results.h5); --force lets the demo be run again into the same OUTDIR.
INPUT=""
REF_ARGS=()
if [ -d "$HERE/recordings" ]; then
    for cand in "$HERE/recordings/xio_ngimu_short_walk.h5" "$HERE"/recordings/*.h5; do
        ref="${cand%.h5}.reference.json"
        if [ -f "$cand" ] && [ -f "$ref" ]; then
            INPUT="$cand"
            REF_ARGS=(--reference "$ref")
            echo "demo: $(basename "$cand") from recordings/"
            break
        fi
    done
fi
if [ -z "$INPUT" ]; then
    for cand in "$HERE/../shared/datasets/xio_ngimu_loops/short_walk/imu.csv.gz" \
                "${BOOTNAV_DATASETS:-/nonexistent}/xio_ngimu_loops/short_walk/imu.csv.gz"; do
        if [ -f "$cand" ]; then INPUT="$cand"; REF_ARGS=(--closed-loop); break; fi
    done
fi
if [ -z "$INPUT" ]; then
    echo "demo: no recording found (looked in recordings/ and the shared datasets)" >&2
    exit 1
fi

echo "demo: processing $INPUT -> $OUT"
"$BOOTNAV" process "$INPUT" --out "$OUT" --force "${REF_ARGS[@]}"
echo
echo "demo: plots (PNG):"
ls -1 "$OUT"/*.png
echo "demo: open $OUT/5_path_2d.png (or $OUT/path.html in a browser) for the path seen from above;"
echo "      $OUT/summary.json holds every figure."
