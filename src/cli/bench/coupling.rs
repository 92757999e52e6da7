//! `codimfx bench coupling`: the two ways of solving eq. (24) on the same
//! states — the monolithic [p, u, λ] system the paper solves, and the
//! reduced [u, p] system with λ eliminated (Schur complement) — both with
//! an incomplete LU and GMRES (the default) or BiCGSTAB (the paper's) to the
//! same tolerance: unknowns, non-zeros,
//! iterations, assembly / factorisation / solve time and the residual of
//! eq. (24) itself, on resting droplets at several resolutions. The
//! monolithic system runs twice: with its particle block stored once for
//! the three components (the default, `coupling.shared_block`) and in
//! general compressed rows (the same iterations and solution), and once
//! with plain ILU(0) instead of the default factorisation with one level of
//! fill in its impulse and pressure rows (`coupling.tail_fill`).
use anyhow::Result;
use clap::Args;
use codimfx::coupling::{Krylov, Method};
use codimfx::step::{step, StageTimes};
use codimfx::validate::droplet::DropletCase;
use codimfx::Real;

/// Arguments of `codimfx bench coupling`.
#[derive(Args, Debug)]
pub struct CouplingArgs {
    /// Resolutions R/Δx.
    #[arg(long, value_delimiter = ',', default_values_t = vec![4.0, 6.0, 8.0])]
    cells: Vec<Real>,
    /// Substeps run per case (the first is from rest; all are timed).
    #[arg(long, default_value_t = 3)]
    substeps: usize,
}

/// Runs the benchmark and prints a markdown table.
pub fn run(a: CouplingArgs) -> Result<()> {
    println!("threads: {}\n", rayon::current_num_threads());
    println!("## eq. (24): monolithic against Schur complement (resting droplet, Δt = 0.003 s, tolerance 1e-9)\n");
    println!("| R/Δx | method | unknowns | non-zeros | iterations | assembly (s) | factor (s) | solve (s) | total (s) | eq. 24 residual | p / (2σ/R) |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for &cells in &a.cells {
        let gmres = Krylov::Gmres {
            restart: codimfx::coupling::GMRES_RESTART,
        };
        let variants = [
            (Method::Monolithic, true, true, gmres, "monolithic"),
            (
                Method::Monolithic,
                true,
                true,
                Krylov::Bicgstab,
                "monolithic, BiCGSTAB",
            ),
            (
                Method::Monolithic,
                false,
                true,
                gmres,
                "monolithic, general rows",
            ),
            (Method::Monolithic, true, false, gmres, "monolithic, ILU(0)"),
            (Method::Schur, true, true, gmres, "Schur"),
            (
                Method::Schur,
                true,
                true,
                Krylov::Bicgstab,
                "Schur, BiCGSTAB",
            ),
        ];
        for (method, shared, fill, krylov, label) in variants {
            let case = DropletCase {
                method,
                ..DropletCase::paper(cells)
            };
            let (mut st, mut prm) = case.build()?;
            if let Some(c) = prm.coupling.as_mut() {
                c.verify = true;
                c.shared_block = shared;
                c.fill_passes = if fill { 2 } else { 0 };
                c.krylov = krylov;
            }
            let (mut it, mut asm, mut fac, mut sol, mut res) = (0, 0.0, 0.0, 0.0, 0.0 as Real);
            let mut last = None;
            for _ in 0..a.substeps {
                let info = step(&mut st, &prm, 0.003, &mut StageTimes::default())?;
                let c = info.coupling.expect("coupled step");
                it += c.iterations;
                asm += c.assemble_s;
                fac += c.factor_s;
                sol += c.solve_s;
                res = res.max(c.eq24_residual.unwrap_or(Real::NAN));
                last = Some(c);
            }
            let c = last.expect("at least one substep");
            let n = a.substeps as Real;
            println!(
                "| {cells} | {label} | {} | {} | {:.1} | {:.3} | {:.3} | {:.3} | {:.3} | {:.1e} | {:.4} |",
                c.unknowns,
                c.nonzeros,
                it as Real / n,
                asm / n,
                fac / n,
                sol / n,
                (asm + fac + sol) / n,
                res,
                c.interior_pressure / case.young_laplace()
            );
        }
    }
    println!("\n(per substep, mean over {} substeps; iterations: GMRES takes one product with A per iteration, BiCGSTAB two; the assembly includes the constraint faces and J, the MLS operators are not counted)", a.substeps);
    Ok(())
}
