#!/usr/bin/env bash
# Blender client test (run by .ci/run only when CODIMFX_DCC=1): surfaces a small mixed scene
# (volume blob, sheet, helix filament, droplets), imports frame 1 into Debian's Blender in
# background mode — the VDB as a volume object meshed by a Volume-to-Mesh modifier on grid
# `surface`, the three PLY files as meshes — checks the counts, and renders a small PNG with
# Cycles on the CPU.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v blender >/dev/null 2>&1; then
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends blender >/dev/null
fi
out="${CODIMFX_DCC_OUT:-$(mktemp -d)}"
mkdir -p "$out"
cargo run --release -q -- bench surface --spacing 0.02 --sphere-radius 0.15 --slab-side 0.5 \
  --slab-thickness 0.06 --extras --write "$out"
cat > "$out/import.py" <<'PY'
import sys, bpy
d = sys.argv[sys.argv.index("--") + 1]
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
bpy.ops.object.volume_import(filepath=d + "/surface.0001.vdb", directory=d,
                             files=[{"name": "surface.0001.vdb"}])
vol = bpy.context.selected_objects[0]
vol.data.grids.load()
names = sorted(g.name for g in vol.data.grids)
assert names == ["surface", "v"], names
vol.hide_render = True
me = bpy.data.meshes.new("levelset")
ob = bpy.data.objects.new("levelset", me)
scene.collection.objects.link(ob)
mod = ob.modifiers.new("v2m", "VOLUME_TO_MESH")
mod.object = vol
mod.grid_name = "surface"
mod.threshold = 0.0
dg = bpy.context.evaluated_depsgraph_get()
nv = len(ob.evaluated_get(dg).to_mesh().vertices)
counts = {"levelset (Volume to Mesh)": nv}
for name in ["mesh", "sheets", "filaments"]:
    bpy.ops.import_mesh.ply(filepath=f"{d}/{name}.0001.ply")
    o = bpy.context.selected_objects[0]
    counts[name] = len(o.data.vertices)
    o.location.y += 1.5 if name == "mesh" else 0.0
print("DCC counts", counts)
assert all(v > 100 for v in counts.values()), counts
cam_data = bpy.data.cameras.new("cam")
cam = bpy.data.objects.new("cam", cam_data)
scene.collection.objects.link(cam)
cam.location = (0.0, -2.6, 1.6)
cam.rotation_euler = (1.05, 0.0, 0.0)
scene.camera = cam
light = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
scene.collection.objects.link(light)
light.rotation_euler = (0.6, 0.2, 0.3)
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = 8
scene.cycles.use_denoising = False
scene.render.resolution_x, scene.render.resolution_y = 240, 160
scene.render.filepath = d + "/render.png"
bpy.ops.render.render(write_still=True)
print("DCC rendered", scene.render.filepath)
PY
blender -b --factory-startup -P "$out/import.py" -- "$out" 2>&1 | tee "$out/blender.log" | grep -E "DCC|Error|error" || true
grep -q "DCC rendered" "$out/blender.log"
test -s "$out/render.png"
echo "dcc: Blender imported and rendered $out/render.png"
