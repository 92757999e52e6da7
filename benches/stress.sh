#!/bin/bash
cd "$(dirname "$0")/.."
mkdir -p "${STRESS_OUT:-/tmp/codimfx-stress}"
# Stress matrix of issue 5 (partial): liquid presets at --scale 2, 10 frames, with Δt × 4 and σ × 10.
# Writes a markdown table to $STRESS_OUT/results.md (needs target/release/codimfx, python3, bc).
out=${STRESS_OUT:-/tmp/codimfx-stress}/results.md
echo "| preset | variant | frames done | result | max speed (m/s) | method switches | curvature clamps | wall (s) |" > $out
echo "|---|---|---|---|---|---|---|---|" >> $out
for p in droplet_on_plane droplet_collision dripping polygon; do
  for v in base dt4 sigma10; do
    f=${STRESS_OUT:-/tmp/codimfx-stress}/${p}_$v.yaml
    /usr/bin/python3 - "$p" "$v" "$f" <<'PY'
import sys,re
p,v,f=sys.argv[1:]
s=open('presets/%s.yaml'%p).read()
if v=='dt4':
    s=re.sub(r'(max_dt:\s*)([0-9.eE-]+)', lambda m: m.group(1)+repr(4*float(m.group(2))), s)
    s=re.sub(r'(\n  cfl:\s*)([0-9.eE-]+)', lambda m: m.group(1)+repr(4*float(m.group(2))), s)
if v=='sigma10':
    s=re.sub(r'(surface_tension:\s*)([0-9.eE-]+)', lambda m: m.group(1)+repr(10*float(m.group(2))), s)
open(f,'w').write(s)
PY
    start=$(date +%s.%N)
    timeout 300 target/release/codimfx sim $f --scale 2 --frames 10 -o ${STRESS_OUT:-/tmp/codimfx-stress}/out > ${STRESS_OUT:-/tmp/codimfx-stress}/${p}_$v.log 2>&1
    rc=$?
    end=$(date +%s.%N)
    res=$(/usr/bin/python3 - "$p" "$v" "$rc" <<'PY'
import sys,json,re
p,v,rc=sys.argv[1:]
try:
    m=json.load(open('${STRESS_OUT:-/tmp/codimfx-stress}/out/%s_%s/manifest.json'%(p,v)))
    fr=m['frames'][1:]
    vmax=max([f['speed']['max'] for f in fr] or [0])
    sw=sum(f['fallbacks'].get('coupling_method_switches',0) for f in fr)
    cc=sum(f.get('surface',{}).get('curvature_clamps',0) for f in fr)
    n=len(fr)
except Exception as e:
    vmax,sw,cc,n=0,0,0,0
log=open('${STRESS_OUT:-/tmp/codimfx-stress}/%s_%s.log'%(p,v)).read()
err=[l for l in log.split('\n') if l.startswith('Error')]
if rc=='0': r='finished, finite'
elif rc=='124': r='timed out (300 s)'
else: r='stopped: '+(err[0][:160].replace('|','/') if err else 'exit '+rc)
print('%d | %s | %.3g | %d | %d'%(n,r,vmax,sw,cc))
PY
)
    echo "| $p | $v | $res | $(printf %.0f $(echo "$end - $start" | bc)) |" >> $out
  done
done
echo DONE >> $out
