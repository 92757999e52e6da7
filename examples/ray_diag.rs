//! Diagnostic of the l = 2 oscillation: the velocity field against the
//! potential flow u = A (−x, 2y, −z) of the mode (elongation along y).
//!
//! `cargo run --release --example ray_diag -- CELLS STEPS` (R = CELLS Δx,
//! Δt = 0.01 s). Per substep: A fitted to the sheet velocities (As), to
//! their normal components (An), to the top particle (Atop) and to the
//! faces deeper than 2Δx (Ad); the particles' kinetic energy over that of
//! the potential flow with A = As or An; the face velocities over A_d D x in
//! depth bins of Δx/2 around the sphere r = R. `BAND_SHEET=1` holds the
//! constraint faces to the sheet's velocity (`coupling.band: sheet`);
//! `AXIS=1` also prints the faces and cells along the x and y axes.
use codimfx::math::{Real, Vec3};
use codimfx::particles::Codim;
use codimfx::step::{step, StageTimes};
use codimfx::validate::droplet::DropletCase;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let cells: Real = args.get(1).map_or(4.0, |s| s.parse().unwrap());
    let nsteps: usize = args.get(2).map_or(20, |s| s.parse().unwrap());
    let case = DropletCase {
        elongation: 0.05,
        band: if std::env::var("BAND_SHEET").is_ok() {
            codimfx::coupling::BandVelocity::Sheet
        } else {
            codimfx::coupling::BandVelocity::Extrapolated
        },
        ..DropletCase::paper(cells)
    };
    let (mut st, prm) = case.build().unwrap();
    let (r, dx, dt) = (case.radius, case.dx, 0.01);
    let d = Vec3::new(-1.0, 2.0, -1.0);
    let nb = 8usize; // depth bins of Δx/2 from −2Δx to +2Δx
    println!("step t A_sheet A_deep A_s/A_d KEratio | band v/(A_d D x) by depth (R−r)/Δx bins of 0.5 from -2 to 2 (- = outside)");
    for n in 0..nsteps {
        let info = step(&mut st, &prm, dt, &mut StageTimes::default()).unwrap();
        let g = &st.grid;
        let t = (n + 1) as Real * dt;
        // deep fit
        let (mut num, mut den) = (0.0, 0.0);
        for a in 0..3 {
            for s in 0..g.slots() {
                if !g.in_domain(s) {
                    continue;
                }
                let x = g.face_pos(s, a);
                if x.norm() < r - 2.0 * dx {
                    let m = d[a] * x[a];
                    num += g.u[a][s] * m;
                    den += m * m;
                }
            }
        }
        let ad = num / den;
        let mut bn = vec![0.0; nb];
        let mut bd = vec![0.0; nb];
        for a in 0..3 {
            for s in 0..g.slots() {
                if !g.in_domain(s) {
                    continue;
                }
                let x = g.face_pos(s, a);
                let depth = (r - x.norm()) / dx;
                let b = ((depth + 2.0) / 0.5).floor();
                if b < 0.0 || b >= nb as Real {
                    continue;
                }
                let m = ad * d[a] * x[a];
                bn[b as usize] += g.u[a][s] * m;
                bd[b as usize] += m * m;
            }
        }
        // sheet fit and KE (particle quadrature; velocities are the grid's)
        let p = &st.particles;
        let (mut sn, mut sd) = (0.0, 0.0);
        let (mut ke, mut kr) = (0.0, 0.0);
        for i in 0..p.len() {
            let dxi = d.component_mul(&p.x[i]);
            if p.codim[i] == Codim::Sheet {
                sn += p.v[i].dot(&dxi);
                sd += dxi.dot(&dxi);
            }
        }
        let as_ = sn / sd;
        // normal-velocity fit of the sheet, and the top particle
        let (mut nn, mut nd) = (0.0, 0.0);
        let mut top = 0;
        for i in 0..p.len() {
            if p.x[i].y > p.x[top].y {
                top = i;
            }
            if p.codim[i] == Codim::Sheet {
                let nh = p.x[i].normalize();
                let m = d.component_mul(&p.x[i]).dot(&nh);
                nn += p.v[i].dot(&nh) * m;
                nd += m * m;
            }
        }
        let an = nn / nd;
        let atop = p.v[top].y / (2.0 * p.x[top].y);
        for i in 0..p.len() {
            let dxi = d.component_mul(&p.x[i]);
            ke += p.mass[i] * p.v[i].norm_squared();
            kr += p.mass[i] * (as_ * dxi).norm_squared();
        }
        let c = info.coupling.as_ref().unwrap();
        // Rayleigh's A(t) = −e ω sin(ωt) / 2 for the same initial deformation
        let w = 2.0 * std::f64::consts::PI / case.rayleigh_period();
        let a_ray = -0.05 * w * (w * t).sin() / 2.0;
        print!("An/A_rayleigh={:.3} ", an / a_ray);
        print!("{:2} {:.2} As={:+.4e} An={:+.4e} Atop={:+.4e} Ad={:+.4e} KE/KE(As)={:.3} KE/KE(An)={:.3} it={} |", n + 1, t, as_, an, atop, ad, ke / kr, ke / kr * (as_ / an).powi(2), c.iterations);
        for b in 0..nb {
            if bd[b] > 0.0 {
                print!(" {:.3}", bn[b] / bd[b]);
            } else {
                print!("  -  ");
            }
        }
        println!();
        if std::env::var("AXIS").is_ok() {
            // faces of component `a` on the positive half of axis `a` (the
            // other two coordinates within half a cell of 0), inside r + 3Δx:
            // (position / Δx, velocity scaled by `scale(position)`), sorted
            let axis = |a: usize, scale: &dyn Fn(Real) -> Real| {
                let mut col: Vec<(Real, Real)> = Vec::new();
                for s in 0..g.slots() {
                    if !g.in_domain(s) {
                        continue;
                    }
                    let x = g.face_pos(s, a);
                    let off = (0..3)
                        .filter(|&b| b != a)
                        .all(|b| x[b].abs() <= 0.5 * dx + 1e-9 && x[b] >= 0.0);
                    if off && x[a] > 0.0 && x[a] < r + 3.0 * dx {
                        col.push((x[a] / dx, g.u[a][s] * scale(x[a])));
                    }
                }
                col.sort_by(|p, q| p.0.partial_cmp(&q.0).unwrap());
                col
            };
            // y-faces along the y axis: v_y / (2 y A_d)
            let col = axis(1, &|y| 1.0 / (2.0 * y));
            println!(
                "   axis y/dx: v_y/(2y) = {:?}",
                col.iter()
                    .map(|(y, v)| format!("{y:.2}:{v:+.4}"))
                    .collect::<Vec<_>>()
            );
            let col = axis(0, &|x| -1.0 / x);
            // divergence of the cells along +y (x = z = 0)
            let mut dv = Vec::new();
            for s in 0..g.slots() {
                if !g.in_domain(s) {
                    continue;
                }
                let c = g.cell_pos(s);
                if c.x.abs() < 1e-9 && c.z.abs() < 1e-9 && c.y >= -1e-9 && c.y < r + 3.0 * dx {
                    let mut div = 0.0;
                    for a in 0..3 {
                        let mut o = [0isize; 3];
                        o[a] = 1;
                        let up = g.neighbor(s, o).map_or(0.0, |t| g.u[a][t]);
                        div += up - g.u[a][s];
                    }
                    dv.push((c.y / dx, div / dx, g.phi[s] / dx));
                }
            }
            dv.sort_by(|a, b| a.0.partial_cmp(&b.0).unwrap());
            println!(
                "   cells y/dx: div (1/s), phi/dx = {:?}",
                dv.iter()
                    .map(|(y, v, p)| format!("{y:.1}:{v:+.3e},{p:+.2}"))
                    .collect::<Vec<_>>()
            );
            println!(
                "   axis x/dx: -v_x/x = {:?}",
                col.iter()
                    .map(|(y, v)| format!("{y:.2}:{v:+.4}"))
                    .collect::<Vec<_>>()
            );
        }
    }
}
