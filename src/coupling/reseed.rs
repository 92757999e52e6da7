//! Reseeding of the sheets and filaments of liquid scenes (paper §9,
//! Algorithm 1 line 3): the sheet of a water bell or a fluid polygon and the
//! surface layer of a spreading droplet stretch, and without new particles
//! they open holes through which the coupled solve's constraint faces are
//! missed. The algorithm is [`crate::reseed`]'s (tangent-grid insertion
//! lifted onto the MLS fit, removal below 0.15 h, exact mass and momentum),
//! applied to the joint sheet/filament set of the store.
//!
//! Particles in a jet's source region ([`Source::protects`]) take part in
//! the fits but are held like boundary particles: they neither seed, donate
//! nor get removed, so the emitted layers keep their Appendix F pattern.
//!
//! When anything changed, the store is rebuilt as "volume and point
//! particles in their old order, then the reseeded sheet and filament
//! particles"; the APIC affine data follows the volume particles (the
//! surface particles carry none).

use super::codim::Source;
use crate::film::shape::FittedShape;
use crate::math::{Mat3, Real, Vec3};
use crate::mls::operators::{par_frames, Neighborhoods};
use crate::mls::{MlsError, MlsParams};
use crate::particles::{Codim, Particles};
use crate::reseed::{reseed_guarded, ReseedCounts, ReseedParams};

/// A filament frame is line-like when its second PCA eigenvalue is at most
/// this fraction of the first (the film step's `clump_ratio` default).
const LINE_RATIO: Real = 0.3;

/// Reseeds the sheet and filament particles of `parts`; keeps `affine`
/// (APIC, empty when unused) aligned with the store.
pub fn reseed_surface(
    parts: &mut Particles,
    affine: &mut Vec<[Vec3; 3]>,
    prm: &ReseedParams,
    mls: &MlsParams,
    sources: &[Source],
) -> Result<ReseedCounts, MlsError> {
    let h = mls.h;
    let nb = Neighborhoods::build(&parts.x, &parts.codim, h)?;
    if nb.is_empty() {
        return Ok(ReseedCounts::default());
    }
    let geom = MlsParams {
        sheet_weight_in_filament: 0.0,
        ..*mls
    };
    let frames = par_frames(&nb, &geom);
    let axes: Vec<Mat3> = frames.iter().map(|f| f.axes).collect();
    let shape = FittedShape {
        nb: &nb,
        frames: &frames,
        mls: &geom,
    };
    // the joint set as its own store; source particles held
    let mut film = Particles {
        next_id: parts.next_id,
        ..Particles::default()
    };
    let mut held = Vec::new();
    for &i in &nb.store {
        let k = film.push(
            parts.x[i],
            parts.v[i],
            parts.mass[i],
            parts.radius[i],
            parts.codim[i],
        );
        film.id[k] = parts.id[i];
        let hold = !parts.fixed[i] && sources.iter().any(|s| s.protects(&parts.x[i], h));
        film.fixed[k] = parts.fixed[i] || hold;
        if hold {
            held.push(parts.id[i]);
        }
    }
    film.next_id = parts.next_id;
    let n_sheet = nb.n_sheet;
    let line_like = |i: usize| {
        let [l1, l2, _] = frames[i].eigenvalues;
        i >= n_sheet && l1 > 0.0 && l2 <= LINE_RATIO * l1
    };
    let volume: Vec<Vec3> = (0..parts.len())
        .filter(|&i| parts.codim[i] == Codim::Volume)
        .map(|i| parts.x[i])
        .collect();
    let counts = reseed_guarded(
        &mut film,
        &axes,
        |i| nb.lists.of(i),
        &shape,
        prm,
        line_like,
        &volume,
    );
    if counts.inserted() + counts.removed() == 0 {
        return Ok(counts);
    }
    held.sort_unstable();
    for k in 0..film.len() {
        if held.binary_search(&film.id[k]).is_ok() {
            film.fixed[k] = false;
        }
    }
    let keep: Vec<bool> = parts
        .codim
        .iter()
        .map(|c| !matches!(c, Codim::Sheet | Codim::Filament))
        .collect();
    if !affine.is_empty() {
        let mut k = 0;
        affine.retain(|_| {
            k += 1;
            keep[k - 1]
        });
        affine.resize(affine.len() + film.len(), [Vec3::zeros(); 3]);
    }
    parts.retain(&keep);
    parts.append(film);
    Ok(counts)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Volume particles in a row, then an 11×11 sheet of spacing 0.4 h
    /// (one particle per tangent cell) in z = 0 with the centre missing,
    /// each particle with its own velocity.
    fn store(h: Real) -> Particles {
        let mut p = Particles::new();
        for k in 0..5 {
            let x = Vec3::new(k as Real * 0.3 * h, 0.0, -3.0 * h);
            p.push(x, Vec3::new(0.0, 0.0, k as Real), 1.0, 0.01, Codim::Volume);
        }
        let s = 0.4 * h;
        for i in 0..11 {
            for j in 0..11 {
                if (i, j) == (5, 5) {
                    continue;
                }
                let x = Vec3::new(i as Real * s, j as Real * s, 0.0);
                let v = Vec3::new(i as Real, -(j as Real), 0.5);
                p.push(x, v, 2.0 + 0.01 * i as Real, 0.001, Codim::Sheet);
            }
        }
        p
    }

    fn momentum(p: &Particles) -> Vec3 {
        (0..p.len()).map(|i| p.v[i] * p.mass[i]).sum()
    }

    #[test]
    fn hole_in_a_liquid_scene_sheet_is_filled_conserving_mass_and_momentum() {
        let h = 0.1;
        let mut p = store(h);
        let mut affine: Vec<[Vec3; 3]> =
            (0..p.len()).map(|i| [Vec3::repeat(i as Real); 3]).collect();
        let (m0, j0, n0) = (p.total_mass(), momentum(&p), p.len());
        let volume: Vec<(u64, Vec3)> = (0..5).map(|i| (p.id[i], p.x[i])).collect();
        let mls = MlsParams::new(h);
        let c = reseed_surface(&mut p, &mut affine, &ReseedParams::paper(h), &mls, &[]).unwrap();
        assert_eq!(c.sheet_inserted, 1, "{c:?}");
        assert_eq!(c.sheet_removed, 0);
        assert_eq!(p.len(), n0 + 1);
        let k = p.len() - 1;
        assert!(
            (p.x[k] - Vec3::new(2.0 * h, 2.0 * h, 0.0)).norm() < 1e-9,
            "{}",
            p.x[k]
        );
        assert!((p.total_mass() - m0).abs() < 1e-12 * m0);
        assert!((momentum(&p) - j0).norm() < 1e-12 * j0.norm());
        // the volume particles keep their order, and their affine data
        for (i, (id, x)) in volume.iter().enumerate() {
            assert_eq!((p.id[i], p.x[i]), (*id, *x));
            assert_eq!(affine[i][0], Vec3::repeat(i as Real));
        }
        assert_eq!(affine.len(), p.len());
        assert!(affine[5..].iter().all(|a| a[0] == Vec3::zeros()));
        // ids stay unique
        let mut ids = p.id.clone();
        ids.sort_unstable();
        ids.dedup();
        assert_eq!(ids.len(), p.len());
    }

    #[test]
    fn particles_in_a_jet_source_are_held() {
        let h = 0.1;
        let mut p = store(h);
        let src = Source {
            origin: Vec3::new(2.0 * h, 2.0 * h, -0.5 * h),
            direction: Vec3::z(),
            radius: 3.0 * h,
            depth: h,
        };
        let before = (p.len(), p.x.clone());
        let mls = MlsParams::new(h);
        let c = reseed_surface(
            &mut p,
            &mut Vec::new(),
            &ReseedParams::paper(h),
            &mls,
            &[src],
        )
        .unwrap();
        assert_eq!(c.sheet_inserted + c.sheet_removed, 0, "{c:?}");
        assert_eq!((p.len(), p.x.clone()), before);
        assert!(p.fixed.iter().all(|f| !f));
    }
}
