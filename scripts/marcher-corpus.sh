#!/usr/bin/env bash
# Wall clock of the cells' marcher against the plain one (`--marcher plain`), paired and
# alternating in one run, on the examples, sphere unions, a custom field, a tiling and a
# turned slab. Prints each scene's median render seconds with both marchers, their ratio
# (cells / plain) and the segments out of steps. Usage: bash scripts/marcher-corpus.sh [RUNS]
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
runs=${1:-3}
bin=target/release/hyperslice
cargo build --release --quiet
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
slab="$out/slab.4ds"
cat > "$slab" <<'SCENE'
render { size = 128 x 128  spp = 1  bounces = 2 }
camera { from = [0, 0, -6, 0] fov = 60deg }
sky = rgb(1)
object slab {
  shape = intersect(halfspace(normal: [0, 0, 1, 0], offset: 1),
                    halfspace(normal: [0, 0, -1, 0], offset: 1)) |> rotate(zw, 10deg)
  material = diffuse(rgb(0.5))
}
SCENE
small=(--size 96x72 --frames 2 --spp 4)
corpus=(
  "d4_packing|examples/d4_packing.4ds ${small[*]}"
  "room|examples/room.4ds ${small[*]}"
  "glass_box|examples/glass_box.4ds ${small[*]}"
  "tesseract|examples/tesseract.4ds ${small[*]}"
  "polytopes|examples/polytopes.4ds ${small[*]}"
  "spheres_16|benches/scenes/spheres.4ds -D n=4"
  "spheres_1024|benches/scenes/spheres.4ds -D n=32"
  "spheres_sdf_625|benches/scenes/spheres_sdf.4ds -D n=25 --spp 16 --size 128x128"
  "grid_tiling|tests/in/grid_lattice.4ds --size 96x60 --spp 4"
  "turned_slab|$slab"
)
echo "machine: $(nproc) cores; $runs paired runs each, --threads 2 --denoise none"
printf "%-16s %9s %9s %7s %6s %6s\n" scene cells_s plain_s ratio oos_c oos_p
for entry in "${corpus[@]}"; do
  name=${entry%%|*}
  read -r -a args <<< "${entry#*|}"
  declare -A times=()
  for _ in $(seq "$runs"); do
    for m in cells plain; do
      stats=$("$bin" render "${args[@]}" --threads 2 --denoise none --marcher "$m" \
        -o "$out/$name.png" --message-format json 2>/dev/null | grep render-stats)
      times[$m]+="$(echo "$stats" | python3 -c 'import json,sys; d=json.load(sys.stdin); print(d["render_seconds"], d["out_of_steps"])') "
    done
  done
  python3 - "$name" "${times[cells]}" "${times[plain]}" <<'PY'
import statistics, sys
name, c, p = sys.argv[1], sys.argv[2].split(), sys.argv[3].split()
ct, co = [float(x) for x in c[0::2]], c[1::2]
pt, po = [float(x) for x in p[0::2]], p[1::2]
mc, mp = statistics.median(ct), statistics.median(pt)
print(f"{name:<16} {mc:9.3f} {mp:9.3f} {mc / mp:7.2f} {co[0]:>6} {po[0]:>6}")
PY
  unset times
done
