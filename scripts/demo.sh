#!/usr/bin/env bash
# Reconstruct the path of a bundled recording and print the summary and the plots' paths.
# Usage: scripts/demo.sh [OUTDIR]   (called by `make demo` after the venv exists)
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
OUT="${1:-out/demo}"
BOOTNAV="${BOOTNAV:-$HERE/.venv/bin/bootnav}"
[ -x "$BOOTNAV" ] || BOOTNAV="bootnav"

# Prefer a recording shipped in recordings/ (bootnav's own HDF5 or a canonical IMU CSV); otherwise the
# x-io NGIMU short closed-loop walk (MIT licence, xioTechnologies/Gait-Tracking) from the shared datasets.
INPUT=""
REF_ARGS=()
if [ -d "$HERE/recordings" ]; then
    INPUT="$(find "$HERE/recordings" -maxdepth 2 -type f \( -name '*.h5' -o -name 'imu.csv.gz' \) | sort | head -n 1)"
    if [ -n "$INPUT" ] && [ -f "$(dirname "$INPUT")/reference.json" ]; then
        REF_ARGS=(--reference "$(dirname "$INPUT")/reference.json")
    fi
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
"$BOOTNAV" process "$INPUT" --out "$OUT" "${REF_ARGS[@]}"
echo
echo "demo: plots (PNG):"
ls -1 "$OUT"/*.png
echo "demo: open $OUT/5_path_2d.png for the path seen from above; $OUT/summary.json holds every figure."
