//! What the frame loop ([`crate::sim`]) reports: a frame's record for the
//! manifest before its substeps fill in their figures, and the line per
//! substep of `codimfx sim -v`.

use crate::io::manifest::{FrameRecord, Speed};
use crate::math::Real;
use crate::particles::{Codim, Particles};
use crate::step::StageTimes;
use std::time::Instant;

/// One line per substep on stderr (`codimfx sim -v`): time, Δt, coupled or
/// pressure solve, particle count, wall time into the frame and the fastest
/// particle; and why the first form of eq. (24) gave up, when it did.
pub(crate) fn report_substep(
    frame: u32,
    substep: u32,
    t: Real,
    dt: Real,
    info: &crate::step::SubstepInfo,
    p: &Particles,
    wall: &Instant,
) {
    let s = &info.pressure.solve;
    let fast = (0..p.len()).max_by(|&a, &b| p.v[a].norm().total_cmp(&p.v[b].norm()));
    let fastest = fast.map_or(String::new(), |i| {
        let x = p.x[i];
        format!(
            "; fastest: {:?} id {} at {:.2} m/s, ({:.4}, {:.4}, {:.4}) m, {:.2e} kg",
            p.codim[i],
            p.id[i],
            p.v[i].norm(),
            x.x,
            x.y,
            x.z,
            p.mass[i]
        )
    });
    eprintln!(
        "frame {frame} substep {substep}: t = {t:.6} s, Δt = {dt:.3e} s, {} iterations, residual {:.1e}, {} particles, {:.1} s into the frame{fastest}",
        s.iterations,
        s.rel_residual,
        p.len(),
        wall.elapsed().as_secs_f64()
    );
    if let Some(e) = info
        .coupling
        .as_ref()
        .and_then(|c| c.first_failure.as_ref())
    {
        eprintln!("  the other form took over after: {e}");
    }
}

/// Smallest, largest and mean particle speed.
pub(crate) fn speed(p: &Particles) -> Speed {
    if p.is_empty() {
        return Speed::default();
    }
    let (mut mn, mut mx, mut sum) = (Real::INFINITY, 0.0 as Real, 0.0);
    for v in &p.v {
        let s = v.norm();
        mn = mn.min(s);
        mx = mx.max(s);
        sum += s;
    }
    Speed {
        min: mn,
        max: mx,
        mean: sum / p.len() as Real,
    }
}

/// A frame's record before its substeps: time, counts, speeds, mass.
pub(crate) fn base_record(frame: u32, time: Real, p: &Particles) -> FrameRecord {
    let c = p.counts();
    FrameRecord {
        frame,
        time,
        next_id: p.next_id,
        counts: Codim::ALL
            .iter()
            .map(|k| (k.name().to_string(), c[*k as usize]))
            .collect(),
        speed: speed(p),
        total_mass: p.total_mass(),
        stage_s: StageTimes::default().0,
        ..Default::default()
    }
}
