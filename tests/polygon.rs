//! The fluid polygon's saw-tooth rim tension sets its corner count (§10.2,
//! Fig. 16): `presets/polygon_fast.yaml` (two opposed jets at Weber 28, a
//! saw-tooth of amplitude 0.9) at `--scale 2`, measured from above with the
//! outline's Fourier modes (`codimfx outline`).
use codimfx::math::Vec3;
use codimfx::outline::outline_modes;
use std::sync::atomic::AtomicBool;

mod common;

#[test]
fn the_saw_tooth_rim_tension_sets_the_polygon_corner_count() {
    // Five teeth: neither the six corners the sheet makes on its own at this
    // Weber number (docs/presets.md) nor a mode of the grid. At this
    // resolution (Δx = 4.2 mm) the outline without the saw-tooth (amplitude
    // 0) has the grid's mode 4 as its strongest at frame 40 (5.1 mm), then
    // 5 (3.1 mm) and 12 (2.7 mm); with five teeth mode 5 reaches 9.1 mm
    // (docs/decisions.md, "The saw-tooth's amplitude"). It must lead,
    // clearly ahead of the next mode.
    let six = "    corners: 6 ";
    let (mut sim, _cache) = common::open_preset("polygon_fast", 40, Some(2.0), |text| {
        assert!(
            text.contains(six) && text.contains("amplitude: 0.9 "),
            "preset changed"
        );
        text.replace(six, "    corners: 5 ")
    });
    let m0 = sim.state.particles.total_mass();
    let centre = Vec3::new(0.2, 0.075, 0.2);
    let mut last = None;
    sim.run(&AtomicBool::new(false), |s, _| {
        last = outline_modes(&s.state.particles, &centre, 72, 12);
    })
    .unwrap();
    let o = last.expect("no sheet at frame 40");
    let top = o.strongest();
    eprintln!(
        "frame 40: mean radius {:.1} mm, strongest modes (k, m) {:?}",
        o.mean_radius * 1e3,
        &top[..3]
    );
    assert_eq!(top[0].0, 5, "strongest modes {:?}", &top[..3]);
    assert!(top[0].1 > 1.3 * top[1].1, "strongest modes {:?}", &top[..3]);
    // the sheet has spread to its Taylor radius at this resolution (~57 mm)
    assert!(o.mean_radius > 0.045, "mean radius {}", o.mean_radius);
    // the jets only add mass
    assert!(sim.state.particles.total_mass() > m0);
    assert!(sim.state.particles.all_finite());
}
