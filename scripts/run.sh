#!/usr/bin/env bash
# Fresh machine → the main job on an embedded default: installs dependencies if missing, builds,
# generates a synthetic KITTI-layout street sequence and runs it through the pipeline.
# Usage: ./scripts/run.sh [FRAMES]   (outputs under ./out/demo)
set -euo pipefail
cd "$(dirname "$0")/.."
FRAMES=${1:-${PLANECELL_DEMO_FRAMES:-20}}
OUT=${PLANECELL_DEMO_OUT:-out/demo}
./scripts/setup.sh
./scripts/build.sh >/dev/null
./scripts/lcm-route.sh  # `planecell run/feed/listen` use LCM multicast
BIN=${PLANECELL_BUILD_DIR:-build}/services/planecell
rm -rf "$OUT"
mkdir -p "$OUT"

echo "== 1/7 synthetic sequence: $FRAMES frames of a generated street"
"$BIN" synth --out "$OUT/sequence" --frames "$FRAMES" --seed 7
echo
echo "== 2/7 what is in it"
"$BIN" info "$OUT/sequence"
echo
echo "== 3/7 SGM disparity of frame 0"
"$BIN" disparity "$OUT/sequence/image_2/000000.png" "$OUT/sequence/image_3/000000.png" \
  -o "$OUT/disparity_000000.pfm" --preview "$OUT/disparity_000000.png"
echo
echo "== 4/7 planecells of frame 0"
"$BIN" extract "$OUT/sequence/image_2/000000.png" "$OUT/sequence/image_3/000000.png" \
  --disparity "$OUT/disparity_000000.pfm" --calib "$OUT/sequence/calib.txt" -o "$OUT/planecells_000000"
echo
echo "== 5/7 stereo accuracy against the renderer's ground truth (planecell SGM vs OpenCV SGBM)"
"$BIN" eval-stereo --dataset synthetic --root "$OUT/sequence" --max-pairs 5 --json "$OUT/eval_stereo.json" \
  --report-md "$OUT/eval_stereo.md"
echo
echo "== 6/7 bench: SGM -> planecells -> world frame -> CRF merge into the global map, against the"
echo "       point-based map and the OctoMap voxel map on the same frames (accuracy, memory, time, views)"
"$BIN" bench "$OUT/sequence" --out "$OUT/bench" --append "$OUT/eval_stereo.md"
echo
echo "== 7/7 the map as coloured polygons"
"$BIN" export "$OUT/bench/map.db" -o "$OUT/map_surfaces.ply" --color surface
"$BIN" export "$OUT/bench/map.db" -o "$OUT/map_rgb.ply" --color rgb
echo
echo "Outputs in $OUT:"
echo "  sequence/                 KITTI odometry layout (image_2/3, calib.txt, poses/00.txt, times.txt, GT disparity + surfaces)"
echo "  disparity_000000.pfm/.png SGM disparity of frame 0 and its colour preview"
echo "  planecells_000000/        overlay.png, dense.pfm, labels.png, cells.ply, cells.json"
echo "  eval_stereo.json/.md      stereo accuracy table (JSON, markdown)"
echo "  bench/                    report.md + report.json (with the replay report), figures (*.png), map.db (the global map)"
echo "  map_surfaces.ply, map_rgb.ply  the map coloured by surface label / image colour (MeshLab, CloudCompare)"
echo
echo "Report: $OUT/bench/report.md"
