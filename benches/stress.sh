#!/bin/bash
# Stress matrix of issue 5: every liquid preset, 10 frames, at a base
# resolution of --scale 2 with Δt × 4 (max_dt and cfl), σ × 10, half
# resolution (--scale 4) and double resolution (--scale 1, the paper's).
# Writes a markdown table to $STRESS_OUT/results.md (needs
# target/release/codimfx and python3). Usage: benches/stress.sh [preset ...]
cd "$(dirname "$0")/.."
dir=${STRESS_OUT:-/tmp/codimfx-stress}
mkdir -p "$dir"
out=$dir/results.md
presets=${*:-droplet_on_plane droplet_collision dripping fluid_chain waterbell polygon}
echo "| preset | variant | frames done | result | max speed (m/s) | method switches | curvature clamps | radius clamps | non-finite | wall (s) |" > "$out"
echo "|---|---|---|---|---|---|---|---|---|---|" >> "$out"
for p in $presets; do
  for v in base dt4 sigma10 half double; do
    f=$dir/${p}_$v.yaml
    python3 - "$p" "$v" "$f" <<'PY'
import sys, re
p, v, f = sys.argv[1:]
s = open('presets/%s.yaml' % p).read()
if v == 'dt4':
    s = re.sub(r'(max_dt:\s*)([0-9.eE-]+)', lambda m: m.group(1) + repr(4 * float(m.group(2))), s)
    s = re.sub(r'(\n  cfl:\s*)([0-9.eE-]+)', lambda m: m.group(1) + repr(4 * float(m.group(2))), s)
if v == 'sigma10':
    s = re.sub(r'(surface_tension:\s*)([0-9.eE-]+)', lambda m: m.group(1) + repr(10 * float(m.group(2))), s)
open(f, 'w').write(s)
PY
    case $v in half) scale=4 ;; double) scale=1 ;; *) scale=2 ;; esac
    start=$(date +%s.%N)
    timeout 300 target/release/codimfx sim "$f" --scale $scale --frames 10 -o "$dir/out" > "$dir/${p}_$v.log" 2>&1
    rc=$?
    end=$(date +%s.%N)
    res=$(python3 - "$dir" "$p" "$v" "$rc" "$start" "$end" <<'PY'
import sys, json, glob, struct
d, p, v, rc, t0, t1 = sys.argv[1:]
n, vmax, sw, cc, rc_, bad = 0, 0.0, 0, 0, 0, 0
try:
    m = json.load(open('%s/out/%s_%s/manifest.json' % (d, p, v)))
    fr = m['frames'][1:]
    n = len(fr)
    vmax = max([f['speed']['max'] for f in fr] or [0])
    sw = sum(f['fallbacks'].get('coupling_method_switches', 0) for f in fr)
    cc = sum(f.get('surface', {}).get('curvature_clamps', 0) for f in fr)
    rc_ = sum(f.get('surface', {}).get('radius_clamps', 0) for f in fr)
    # every written frame's floats must be finite (the writer refuses NaN; check anyway)
    for path in sorted(glob.glob('%s/out/%s_%s/particles.*.ply' % (d, p, v))):
        b = open(path, 'rb').read()
        h = b.index(b'end_header\n') + len(b'end_header\n')
        hdr = b[:h].decode()
        cnt = int([l for l in hdr.split('\n') if l.startswith('element vertex')][0].split()[2])
        props = [l.split() for l in hdr.split('\n') if l.startswith('property')]
        fmt = {'double': 'd', 'float': 'f', 'uint': 'I', 'uchar': 'B', 'int': 'i', 'uint64': 'Q', 'ulong': 'Q'}
        rec = '<' + ''.join(fmt[q[1]] for q in props)
        size = struct.calcsize(rec)
        fl = [i for i, q in enumerate(props) if q[1] in ('double', 'float')]
        for k in range(cnt):
            t = struct.unpack_from(rec, b, h + k * size)
            if any(not (t[i] == t[i] and abs(t[i]) != float('inf')) for i in fl):
                bad += 1
except Exception as e:
    pass
log = open('%s/%s_%s.log' % (d, p, v)).read()
err = [l for l in log.split('\n') if l.startswith('Error')]
if rc == '0':
    r = 'finished, finite'
elif rc == '124':
    r = 'timed out (300 s), finite so far'
else:
    r = 'stopped: ' + (err[0][:160].replace('|', '/') if err else 'exit ' + rc)
print('%d | %s | %.3g | %d | %d | %d | %d | %.0f' % (n, r, vmax, sw, cc, rc_, bad, float(t1) - float(t0)))
PY
)
    echo "| $p | $v | $res |" >> "$out"
  done
done
echo DONE >> "$out"
