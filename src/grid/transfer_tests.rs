//! Unit tests of [`crate::grid::transfer`] (kept apart to keep the module short).
use super::*;

#[test]
fn bodies_are_components_of_touching_cells() {
    // two 3³ lattices of spacing 0.25 (cell 0.5): with a gap of 1.0
    // between them they are two bodies; with 0.01 (cells touching) one;
    // a sheet particle belongs to none
    let labels = |gap: Real| {
        let mut p = Particles::default();
        for x0 in [0.0, 0.5 + gap] {
            for i in 0..3 {
                for j in 0..3 {
                    for k in 0..3 {
                        let x =
                            Vec3::new(x0 + 0.25 * i as Real, 0.25 * j as Real, 0.25 * k as Real);
                        p.push(x, Vec3::zeros(), 1.0, 0.1, Codim::Volume);
                    }
                }
            }
        }
        p.push(
            Vec3::new(-1.0, 0.0, 0.0),
            Vec3::zeros(),
            1.0,
            0.1,
            Codim::Sheet,
        );
        body_labels(&p, 0.5)
    };
    let l = labels(1.0);
    assert!(l[..27].iter().all(|&b| b == l[0]));
    assert!(l[27..54].iter().all(|&b| b == l[27]));
    assert_ne!(l[0], l[27]);
    assert_eq!(l[54], u32::MAX);
    let l = labels(0.01);
    assert!(l[..54].iter().all(|&b| b == l[0]));
}

/// Liquid cells of two slabs of volume particles (spacing Δx/3) whose
/// facing layers are `gap` apart, `second` false for the first slab alone:
/// (φ < 0 per slot, cell centres).
fn slabs(gap: Real, second: bool, open_gaps: bool) -> (Vec<bool>, Vec<Vec3>) {
    let dx = 0.05;
    let s = dx / 3.0;
    let mut p = Particles::default();
    let mut slab = |x0: Real, x1: Real| {
        let n = ((x1 - x0) / s).round() as usize;
        for i in 0..=n {
            for j in 0..=24 {
                for k in 0..=24 {
                    let x = Vec3::new(x0 + s * i as Real, 0.3 + s * j as Real, 0.3 + s * k as Real);
                    p.push(x, Vec3::zeros(), 1.0, 0.1, Codim::Volume);
                }
            }
        }
    };
    slab(0.2, 0.45);
    if second {
        slab(0.45 + gap, 0.75);
    }
    let mut g = MacGrid::new(Vec3::zeros(), Vec3::repeat(1.0), dx);
    transfer_to_grid(
        &mut g,
        &p,
        &SolidSet::default(),
        2,
        1.0,
        false,
        open_gaps,
        None,
    );
    let liquid = (0..g.slots())
        .map(|t| g.in_domain(t) && g.phi[t] < 0.0)
        .collect();
    let centre = (0..g.slots()).map(|t| g.cell_pos(t)).collect();
    (liquid, centre)
}

#[test]
fn open_gaps_separate_close_surfaces_and_leave_one_body_alone() {
    let dx = 0.05;
    // a lone slab: the rule finds no gap anywhere
    assert_eq!(slabs(0.0, false, true), slabs(0.0, false, false));
    for gap in [1.0 * dx, 1.2 * dx, 1.6 * dx, 1.9 * dx, 2.2 * dx] {
        // rows along x through the middle of the slabs that are liquid all
        // the way across the gap (the two slabs joined on the grid)
        let joined = |open: bool| {
            let (liquid, c) = slabs(gap, true, open);
            let mut rows = std::collections::BTreeMap::new();
            for t in 0..liquid.len() {
                let x = c[t].x;
                if x > 0.45
                    && x < 0.45 + gap
                    && (0.35..0.65).contains(&c[t].y)
                    && (0.35..0.65).contains(&c[t].z)
                {
                    let key = ((c[t].y / dx) as i64, (c[t].z / dx) as i64);
                    *rows.entry(key).or_insert(true) &= liquid[t];
                }
            }
            assert!(!rows.is_empty());
            rows.values().filter(|&&all| all).count()
        };
        assert!(joined(false) > 0, "gap {gap}: the level sets do not meet");
        assert_eq!(
            joined(true),
            0,
            "gap {gap}: the slabs are joined on the grid"
        );
        // the slabs' interiors stay liquid
        let (liquid, c) = slabs(gap, true, true);
        let inside = (0..liquid.len())
            .filter(|&t| {
                (c[t].x > 0.2 + 0.5 * dx && c[t].x < 0.45 - 1.5 * dx)
                    && (0.35..0.65).contains(&c[t].y)
                    && (0.35..0.65).contains(&c[t].z)
            })
            .collect::<Vec<_>>();
        assert!(!inside.is_empty() && inside.iter().all(|&t| liquid[t]));
    }
}
