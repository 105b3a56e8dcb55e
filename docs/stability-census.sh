#!/usr/bin/env bash
# The bad-input census of docs/STABILITY.md: runs the workbench on every bad input listed below
# and prints one Markdown table row each (exit code and the first line of stderr).
#
#   bash docs/stability-census.sh [path/to/workbench] > census.md
#
# Needs python3 (to write the glTF fixtures), xvfb-run (the viewer rows) and, for the permission rows, setpriv (the script
# then runs those as user nobody, since root reads every file).
set -uo pipefail
WB="${1:-target/debug/workbench}"
WB="$(realpath "$WB")"
REPO="$(cd "$(dirname "$0")/.." && pwd)"
T="$(mktemp -d)"
trap 'rm -rf "$T"' EXIT
cd "$T"

# Scene files.
: > empty.toml
printf 'name = "x"\n[[object]\nplane = { size = [1, 1] }\n' > syntax.toml
printf '[[object]]\nplane = { size = [1, 1] }\ncolour = 3\n' > unknown-key.toml
printf '[[object]]\nplane = { size = "big" }\n' > wrong-type.toml
printf '[[object]]\nplane = { size = [1, 1] }\nbox = { size = [1, 1, 1] }\n' > two-sources.toml
printf '[[object]]\nbox = { size = [1, -1, 1] }\n' > negative-box.toml
printf '[[object]]\nsphere = { radius = 1, segments = 5000 }\n' > segments.toml
for k in 1 2 3; do printf '[[object]]\nsphere = { radius = 1, segments = 4096 }\n'; done > too-many-triangles.toml
printf '[light]\ndirection = [0, -1, 0]\ntarget = [0, 0, 0]\n[[object]]\nplane = { size = [1, 1] }\n' > direction-and-target.toml
printf '[light]\nwidth = nan\n[[object]]\nplane = { size = [1, 1] }\n' > light-nan.toml
printf '[light]\ndirection = [0, 0, 0]\n[[object]]\nplane = { size = [1, 1] }\n' > light-zero-direction.toml
printf '[light]\nwidth = -1\n[[object]]\nplane = { size = [1, 1] }\n' > light-negative.toml
printf '[[object]]\nplane = { size = [1, 1] }\ntranslation = [inf, 0, 0]\n' > transform-inf.toml
printf '[[object]]\nplane = { size = [1, 1] }\nreceives_shadow = false\n' > no-receiver.toml
printf 'name = "\xff\xfe"\n' > not-utf8.toml
printf '[[object]]\ngltf = "missing.glb"\n' > missing-gltf.toml
python3 -c 'print("a = " + "[" * 100000 + "]" * 100000)' > deep-nesting.toml
printf '[[object]]\nplane = { size = [1, 1] }\n' > unreadable.toml && chmod 000 unreadable.toml
printf 'solid x\nendsolid x\n' > model.stl

# glTF and GLB files.
python3 - <<'EOF'
import base64, json, struct
tri = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 0, 1)
def gltf(nodes, scene_nodes, accessor_count=3, buffer_uri=None, mode=4, data=tri):
    uri = buffer_uri or "data:application/octet-stream;base64," + base64.b64encode(data).decode()
    return {
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": len(data), "uri": uri}],
        "bufferViews": [{"buffer": 0, "byteLength": len(data)}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": accessor_count, "type": "VEC3",
                       "min": [0, 0, 0], "max": [1, 0, 1]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "mode": mode}]}],
        "nodes": nodes,
        "scenes": [{"nodes": scene_nodes}],
        "scene": 0,
    }
def write(name, doc):
    open(name, "w").write(json.dumps(doc))
write("cycle.gltf", gltf([{"mesh": 0, "children": [1]}, {"children": [0]}], [0]))
write("absurd-count.gltf", gltf([{"mesh": 0}], [0], accessor_count=4_000_000_000))
# 40 levels, each node using both nodes of the next level: 2^40 paths in 3 kB.
nodes = []
for level in range(40):
    children = [2 * level + 2, 2 * level + 3] if level < 39 else []
    nodes += [{"mesh": 0, "children": children}, {"mesh": 0, "children": children}]
write("exponential.gltf", gltf(nodes, [0]))
write("points.gltf", gltf([{"mesh": 0}], [0], mode=0))
write("missing-buffer.gltf", gltf([{"mesh": 0}], [0], buffer_uri="missing.bin"))
write("device-buffer.gltf", gltf([{"mesh": 0}], [0], buffer_uri="file:///dev/zero"))
open("syntax.gltf", "w").write('{"asset": {"version": "2.0"}, "nodes": [')
write("no-mesh.gltf", {"asset": {"version": "2.0"}, "nodes": [{}], "scenes": [{"nodes": [0]}]})
# glTF 1.0 (objects in dictionaries), and a file that requires Draco mesh compression.
write("gltf-1.gltf", {"asset": {"version": "1.0"}, "meshes": {"m": {"primitives": []}}})
draco = gltf([{"mesh": 0}], [0])
draco["extensionsUsed"] = draco["extensionsRequired"] = ["KHR_draco_mesh_compression"]
write("draco.gltf", draco)
# A GLB cut in half, and one of garbage.
doc = json.dumps(gltf([{"mesh": 0}], [0])).encode()
doc += b" " * (-len(doc) % 4)
glb = b"glTF" + struct.pack("<II", 2, 12 + 8 + len(doc)) + struct.pack("<I4s", len(doc), b"JSON") + doc
open("truncated.glb", "wb").write(glb[: len(glb) // 2])
open("garbage.glb", "wb").write(b"glTF\x02\x00\x00\x00garbage")
EOF
# The glTF fuzz target's findings (regression tests in crates/scenes/tests).
cp "$REPO"/crates/scenes/tests/data/fuzz-gltf-*.gl* .

# Sweep files.
printf 'scenes = []\n[[technique]]\nid = "hard"\n' > sweep-no-scenes.toml
printf 'scenes = ["atty-square"]\n' > sweep-no-technique.toml
printf 'scenes = ["atty-square"]\nspeed = 3\n[[technique]]\nid = "hard"\n' > sweep-unknown-key.toml
printf 'scenes = ["atty-square"]\n[[technique]]\nid = "pcss"\n[technique.params]\nfilter_samples = [%s]\nblocker_samples = [%s]\nshadow_map_size = [%s]\n' \
  "$(seq -s, 1 256)" "$(seq -s, 1 64)" "$(seq -s, 64 200)" > sweep-huge-grid.toml
printf 'scenes = ["atty-square"]\n[reference]\nsamples_per_axis = 1000\n[[technique]]\nid = "hard"\n' > sweep-bad-reference.toml
printf 'scenes = ["atty-square"]\n[camera]\neye = [0, 1, 0]\ntarget = [0, 1, 0]\nup = [0, 1, 0]\nfov_y_degrees = 45\nnear = 0.1\nfar = 10\n[[technique]]\nid = "hard"\n' > sweep-bad-camera.toml
printf 'scenes = ["atty-square"]\n[[technique]]\nid = "hard"\n[technique.params]\nshadow_map_size = []\n' > sweep-empty-list.toml

# Viewer state files.
printf '{"version": 1, "scene": "atty-square"' > state-truncated.json
printf '{"version": 7, "scene": "atty-square", "technique": "pcss", "camera": {"eye": [0,3,5], "target": [0,0,0], "up": [0,1,0], "fov_y_degrees": 45, "near": 0.05, "far": 100}, "light": {"center": [0,4,0], "direction": [0,-1,0], "up": [0,0,1], "width": 1, "height": 1, "intensity": 1}}' > state-version.json

# A finished benchmark (for --resume rows) and one whose sweep then changed.
printf 'size = "16x16"\nframes = 1\nwarmup = 0\nscenes = ["atty-square"]\n[[technique]]\nid = "hard"\n' > small-sweep.toml
"$WB" bench --sweep small-sweep.toml --no-error --no-images --out finished >/dev/null 2>&1
printf 'size = "16x16"\nframes = 1\nwarmup = 0\nscenes = ["atty-square", "stiff-fusion"]\n[[technique]]\nid = "hard"\n' > small-sweep.toml
mkdir -p not-a-benchmark readonly-parent
chmod 555 readonly-parent

row() { # kind, description, command...
  local kind="$1" what="$2"
  shift 2
  "$@" >/dev/null 2>"$T/stderr"
  local code=$?
  local err
  # Mesa 25 also says, as user nobody (whose HOME, /root, it cannot write), that it works
  # without its on-disk shader cache: noise like XDG_RUNTIME_DIR's.
  err="$(grep -v -e XDG_RUNTIME_DIR -e 'for shader cache (.*)---disabling' \
    -e '^\[20[0-9-]*T[0-9:]*Z \(WARN\|ERROR\) ' -e '^\s*$' "$T/stderr")"
  local lines
  lines=$(printf '%s' "$err" | grep -c .)
  err="${err//|/\\|}"
  printf '| %s | %s | %s | %s | `%s` |\n' "$kind" "$what" "$code" "$lines" "$(printf '%s' "$err" | head -n 1)"
}
B=("$WB" bench --technique hard --size 16x16 --frames 1 --no-error --no-images --out "$T/out")
S=("$WB" bench --scene atty-square --size 16x16 --frames 1 --no-error --no-images --out "$T/out")
NOBODY=(setpriv --reuid=65534 --regid=65534 --clear-groups)

echo '| kind | bad input | exit | lines | message (first line of stderr) |'
echo '|---|---|---|---|---|'
row "scene spec" "unknown id \`no-such-scene\`" "${B[@]}" --scene no-such-scene
row "scene spec" "unknown parameter \`atty-square:wat=1\`" "${B[@]}" --scene atty-square:wat=1
row "scene spec" "not a number \`atty-square:light_width=abc\`" "${B[@]}" --scene atty-square:light_width=abc
row "scene spec" "NaN \`atty-square:light_width=NaN\`" "${B[@]}" --scene atty-square:light_width=NaN
row "scene spec" "infinity \`atty-square:light_width=inf\`" "${B[@]}" --scene atty-square:light_width=inf
row "scene spec" "out of range \`atty-square:light_width=100\`" "${B[@]}" --scene atty-square:light_width=100
row "scene spec" "given twice \`atty-square:light_width=1,light_width=2\`" "${B[@]}" --scene atty-square:light_width=1,light_width=2
row "scene spec" "no value \`atty-square:light_width\`" "${B[@]}" --scene atty-square:light_width
row "scene spec" "no name \`atty-square:=1\`" "${B[@]}" --scene atty-square:=1
row "scene file" "empty TOML file" "${B[@]}" --scene empty.toml
row "scene file" "TOML syntax error" "${B[@]}" --scene syntax.toml
row "scene file" "unknown key \`colour\`" "${B[@]}" --scene unknown-key.toml
row "scene file" "wrong type (\`size = \"big\"\`)" "${B[@]}" --scene wrong-type.toml
row "scene file" "two mesh sources in one object" "${B[@]}" --scene two-sources.toml
row "scene file" "negative box size" "${B[@]}" --scene negative-box.toml
row "scene file" "sphere segments 5000" "${B[@]}" --scene segments.toml
row "scene file" "three 4096-segment spheres (33 M triangles each)" "${B[@]}" --scene too-many-triangles.toml
row "scene file" "arrays nested 100,000 deep" "${B[@]}" --scene deep-nesting.toml
row "scene file" "not UTF-8" "${B[@]}" --scene not-utf8.toml
row "scene file" "glTF object whose file is missing" "${B[@]}" --scene missing-gltf.toml
row "scene file" "no receiver (\`receives_shadow = false\`)" "${B[@]}" --scene no-receiver.toml
row "scene file" "infinite translation" "${B[@]}" --scene transform-inf.toml
row "light" "both \`direction\` and \`target\`" "${B[@]}" --scene direction-and-target.toml
row "light" "\`width = nan\`" "${B[@]}" --scene light-nan.toml
row "light" "zero direction" "${B[@]}" --scene light-zero-direction.toml
row "light" "negative width" "${B[@]}" --scene light-negative.toml
row "glTF" "truncated GLB (half the file)" "${B[@]}" --scene truncated.glb
row "glTF" "GLB of garbage" "${B[@]}" --scene garbage.glb
row "glTF" "JSON syntax error" "${B[@]}" --scene syntax.gltf
row "glTF" "cyclic node graph" "${B[@]}" --scene cycle.gltf
row "glTF" "accessor count 4,000,000,000" "${B[@]}" --scene absurd-count.gltf
row "glTF" "nodes reusing children: 2^40 paths in 3 kB" "${B[@]}" --scene exponential.gltf
row "glTF" "only a point primitive" "${B[@]}" --scene points.gltf
row "glTF" "no meshes" "${B[@]}" --scene no-mesh.gltf
row "glTF" "external buffer missing" "${B[@]}" --scene missing-buffer.gltf
row "glTF" "POSITION accessor index past the accessors (fuzz finding)" "${B[@]}" --scene fuzz-gltf-position-accessor-past-the-end.gltf
row "glTF" "VEC2 POSITION accessor in a GLB (fuzz finding)" "${B[@]}" --scene fuzz-gltf-vec2-positions.glb
row "glTF" "buffer \`file:///dev/zero\`" "${B[@]}" --scene device-buffer.gltf
row "glTF" "glTF 1.0" "${B[@]}" --scene gltf-1.gltf
row "glTF" "requires Draco compression (\`KHR_draco_mesh_compression\`)" "${B[@]}" --scene draco.gltf
row "path" "scene file that does not exist" "${B[@]}" --scene /nonexistent/scene.toml
row "path" "unsupported extension (\`.stl\`)" "${B[@]}" --scene model.stl
row "path" "\`--out\` under a regular file" "$WB" bench --scene atty-square --technique hard --size 16x16 --frames 1 --no-error --no-images --out "$T/model.stl/out"
row "permissions" "unreadable scene file (as nobody)" "${NOBODY[@]}" "${B[@]}" --scene "$T/unreadable.toml"
row "permissions" "\`--out\` in a read-only folder (as nobody)" "${NOBODY[@]}" "$WB" bench --scene atty-square --technique hard --size 16x16 --frames 1 --no-error --no-images --out "$T/readonly-parent/out"
row "technique" "unknown technique" "${S[@]}" --technique nope
row "parameter" "unknown parameter" "${S[@]}" --technique pcss --param wat=1
row "parameter" "out of range \`filter_samples=100000\`" "${S[@]}" --technique pcss --param filter_samples=100000
row "parameter" "NaN \`bias_texels=NaN\`" "${S[@]}" --technique pcss --param bias_texels=NaN
row "parameter" "infinite \`bias_texels=inf\`" "${S[@]}" --technique pcss --param bias_texels=inf
row "parameter" "wrong type \`filter_samples=1.5\`" "${S[@]}" --technique pcss --param filter_samples=1.5
row "parameter" "unknown choice \`kernel=hexagon\`" "${S[@]}" --technique pcss --param kernel=hexagon
row "parameter" "no \`=\` (\`filter_samples\`)" "${S[@]}" --technique pcss --param filter_samples
row "parameter" "bad reference parameter" "${S[@]}" --technique hard --reference-param samples_per_axis=0
row "size" "\`--size 0x64\`" "$WB" bench --scene atty-square --technique hard --size 0x64 --out "$T/out"
row "size" "\`--size 100000x64\`" "$WB" bench --scene atty-square --technique hard --size 100000x64 --out "$T/out"
row "size" "\`--size big\`" "$WB" bench --scene atty-square --technique hard --size big --out "$T/out"
row "size" "\`--frames 0\`" "$WB" bench --scene atty-square --technique hard --frames 0 --out "$T/out"
row "option" "\`--timing fast\`" "${S[@]}" --technique hard --timing fast
row "option" "\`--shard 3/3\`" "$WB" bench --sweep small-sweep.toml --shard 3/3 --out "$T/out"
row "option" "\`--shard\` without a sweep" "${S[@]}" --technique hard --shard 0/2
row "option" "unknown suite" "$WB" bench --suite nope --out "$T/out"
row "sweep" "sweep file missing" "$WB" bench --sweep missing.toml --out "$T/out"
row "sweep" "empty \`scenes\`" "$WB" bench --sweep sweep-no-scenes.toml --out "$T/out"
row "sweep" "no \`[[technique]]\`" "$WB" bench --sweep sweep-no-technique.toml --out "$T/out"
row "sweep" "unknown key" "$WB" bench --sweep sweep-unknown-key.toml --out "$T/out"
row "sweep" "grid of 5 million runs" "$WB" bench --sweep sweep-huge-grid.toml --out "$T/out"
row "sweep" "empty value list" "$WB" bench --sweep sweep-empty-list.toml --out "$T/out"
row "sweep" "reference \`samples_per_axis = 1000\`" "$WB" bench --sweep sweep-bad-reference.toml --out "$T/out"
row "sweep" "camera eye = target" "$WB" bench --sweep sweep-bad-camera.toml --out "$T/out"
row "interrupted run" "\`--resume\` of a folder that is no benchmark" "$WB" bench --resume not-a-benchmark
row "interrupted run" "\`--resume\` after the sweep file changed" "$WB" bench --resume finished
row "interrupted run" "\`--resume\` of a folder that does not exist" "$WB" bench --resume /nonexistent/out
row "merge" "merge of a folder without results.json" "$WB" merge not-a-benchmark --out "$T/merged"
row "GPU" "no adapter (\`WGPU_BACKEND=metal\`)" env WGPU_BACKEND=metal "${S[@]}" --technique hard
row "GPU" "\`WGPU_ADAPTER_NAME=nonexistent\`" env WGPU_ADAPTER_NAME=nonexistent "${S[@]}" --technique hard
row "viewer state" "truncated JSON" xvfb-run -a "$WB" view --state state-truncated.json --frames 1
row "viewer state" "unsupported version 7" xvfb-run -a "$WB" view --state state-version.json --frames 1
