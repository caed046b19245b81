#!/usr/bin/env bash
# Renders the picture of every shape, operation and material into docs/gallery/shapes/, writes
# docs/shapes.md around them, and renders the tutorial's steps (docs/tutorial/step*.4ds) next
# to their scenes. Run from the repository root: bash scripts/gallery.sh
set -euo pipefail
cargo build --release --quiet
bin="${CARGO_TARGET_DIR:-target}/release/hyperslice"
out=docs/gallery/shapes
mkdir -p "$out"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# One small scene per entry: NAME|SHAPE|MATERIAL|what it shows.
entries=$(cat <<'TABLE'
hypersphere|hypersphere(0.8)|diffuse(#d05030)|the 4D ball; every slice is a ball
halfspace|halfspace(normal: [1, 1, 0, 0.5], offset: -0.3)|diffuse(#d05030)|everything on one side of a hyperplane
hyperbox|hyperbox(0.6, radius: 0.05) \|> rotate(xw, 30deg)|diffuse(#d05030)|a tesseract, turned in xw so its slice is not a cube
spherinder|spherinder(radius: 0.6, height: 0.5) \|> rotate(zw, 40deg)|diffuse(#d05030)|a ball extruded along w
cubinder|cubinder(radius: 0.5, height: 0.5) \|> rotate(xw, 30deg)|diffuse(#d05030)|a cylinder extruded along w
duocylinder|duocylinder(0.6, 0.6) \|> rotate(xw, 25deg) \|> rotate(yw, 25deg)|diffuse(#d05030)|the product of two disks
cell5|cell5(1) \|> rotate(xw, 25deg)|diffuse(#d05030)|the 5-cell (4-simplex)
cell16|cell16(1) \|> rotate(xw, 25deg)|diffuse(#d05030)|the 16-cell (cross-polytope)
cell24|cell24(0.9) \|> rotate(xw, 25deg)|diffuse(#d05030)|the 24-cell
sdf|sdf \|p\| length(vec4(length(vec4(p.x, p.y, 0, 0)) - 0.6, p.z, p.w, 0)) - 0.3|diffuse(#d05030)|a custom distance function: a thickened circle
union|union(hypersphere(0.5) \|> translate([-0.45, 0, 0, 0]), hyperbox(0.4) \|> translate([0.45, 0, 0, 0]), smooth: 0.15)|diffuse(#d05030)|both shapes, blended where they meet
intersect|intersect(hypersphere(0.8), hyperbox(0.6))|diffuse(#d05030)|where both shapes are
subtract|subtract(hyperbox(0.6), hypersphere(0.75))|diffuse(#d05030)|the first shape with the second cut away
onion|subtract(onion(hypersphere(0.8), 0.05), halfspace(normal: [0, -1, 0, 0], offset: -0.3))|diffuse(#d05030)|a shell (its top cut away to show it)
round|round(hyperbox(0.45), 0.2)|diffuse(#d05030)|grown and rounded by a radius
translate|hypersphere(0.5) \|> translate([0.5, 0, 0, 0])|diffuse(#d05030)|moved by a vec4
scale|cell16(1) \|> scale(0.6)|diffuse(#d05030)|scaled by a factor
symmetry|hypersphere(0.35) \|> translate([0.5, 0, 0, 0]) \|> symmetry([1, 0, 0, 0])|diffuse(#d05030)|mirrored across a hyperplane
rotate|hyperbox(0.55) \|> rotate(xw, 45deg)|diffuse(#d05030)|turned in a plane (here xw)
tile|hypersphere(0.28) \|> tile(grid(0.6, limit: [2, 0, 2, 0]))|diffuse(#d05030)|repeated on a lattice (here a finite grid)
diffuse|hypersphere(0.8)|diffuse(albedo: #d05030)|a matte surface
light|hypersphere(0.8)|light(rgb(1, 0.8, 0.6), intensity: 2)|a glowing surface
mirror|hypersphere(0.8)|mirror()|a perfect mirror
glass|hypersphere(0.8)|glass(ior: 1.5, tint: rgb(0.8, 0.9, 1))|refracting glass
shiny|hypersphere(0.8)|shiny(roughness: 0.2, color: #d4af37)|a rough metal
fog|hypersphere(0.8)|fog(extinction: 3, albedo: 0.9)|a volume that scatters light
material map|hypersphere(0.8)|\|p, n\| if (floor(p.x * 4) + floor(p.y * 4)) mod 2 == 0 { diffuse(0.9) } else { diffuse(#d05030) }|a material per point: `\|p, n\| ...`
TABLE
)

page=docs/shapes.md
{
  echo "# Shapes, operations and materials"
  echo
  echo "Every builtin shape, shape operation and material, each rendered in the slice \`w = 0.2\`"
  echo "of a small scene (a floor, a lamp, a pale sky). \`bash scripts/gallery.sh\` renders them"
  echo "and writes this page. Parameters are in [the language reference](language.md) (sections"
  echo "9, 10 and 12)."
  echo
  echo "| | name | written as | what it is |"
  echo "|---|---|---|---|"
} > "$page"

# Without -r, `read` takes `\|` as a `|` inside a field rather than a separator.
# shellcheck disable=SC2162
while IFS='|' read name shape material what; do
  file=${name// /_}
  plain_shape=$shape
  plain_material=$material
  # Markdown tables need `|` escaped.
  shape=${shape//|/\\|}
  material=${material//|/\\|}
  what=${what//|/\\|}
  cat > "$work/$file.4ds" <<SCENE
render { size = 128 x 96  spp = 32  bounces = 4 }
camera { from = [0, 0.5, -3, 0.2]  look = rotate(yz, 10deg)  fov = 55deg }
sky = rgb(0.55, 0.65, 0.8)
object floor { shape = halfspace(offset: -1.1), material = diffuse(rgb(0.6)) }
object lamp { shape = hypersphere(0.5) |> translate([1.5, 2.5, -2, 0]), material = light(intensity: 60) }
object it { shape = $plain_shape, material = $plain_material }
SCENE
  "$bin" render "$work/$file.4ds" -o "$out/$file.png" 2> "$work/$file.log" || { cat "$work/$file.log"; exit 1; }
  if [[ $material == diffuse\(#d05030\) ]]; then
    written="\`$shape\`"
  else
    written="\`$material\`"
  fi
  echo "| ![$name](gallery/shapes/$file.png) | \`$name\` | $written | $what |" >> "$page"
done <<< "$entries"

for step in docs/tutorial/step*.4ds; do
  ext=png
  grep -q "frames" "$step" && ext=gif
  "$bin" render "$step" -o "${step%.4ds}.$ext" 2> "$work/step.log" || { cat "$work/step.log"; exit 1; }
done
echo "wrote $page, $out/ and docs/tutorial/*.png"
