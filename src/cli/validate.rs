//! `codimfx validate <case>`: the MLS operators against analytic solutions.
//! Prints a table; `--json` prints the figures as one JSON object instead.
use anyhow::{Context, Result};
use clap::{Args, Subcommand, ValueEnum};
use codimfx::mls::{MlsParams, Weighting};
use codimfx::validate::butterfly::Butterfly;
use codimfx::validate::curvature::{curvature_study, CurvatureShape};
use codimfx::validate::sphere_diffusion::{convergence, EigenMethod, Scheme, SphereDiffusion};
use codimfx::validate::time::LinearSolver;
use codimfx::Real;

/// Arguments of `codimfx validate`.
#[derive(Args, Debug)]
pub struct ValidateArgs {
    #[command(subcommand)]
    case: Case,
}

/// Operator flags shared by the cases.
#[derive(Args, Debug, Clone)]
struct OperatorArgs {
    /// Polynomial order of the MLS fits (2 = the paper's quadratic; default 4).
    #[arg(long, default_value_t = 4)]
    order: usize,
    /// Operator exactly as the paper writes it: quadratic fit, eq. 32 weights,
    /// no metric-derivative term (overrides --order and --no-christoffel).
    #[arg(long)]
    paper: bool,
    /// Drop the metric-derivative (Christoffel) term of the Laplace–Beltrami operator.
    #[arg(long)]
    no_christoffel: bool,
    /// Fit weights: `paper` (eq. 32) or `wendland` (smooth; shown unstable).
    #[arg(long, value_enum, default_value_t = WeightArg::Paper)]
    weights: WeightArg,
}

#[derive(ValueEnum, Clone, Copy, Debug)]
enum WeightArg {
    Paper,
    Wendland,
}

impl OperatorArgs {
    fn params(&self, h: Real) -> MlsParams {
        let mut p = if self.paper {
            MlsParams::paper(h)
        } else {
            MlsParams::new(h)
        };
        if !self.paper {
            p.order = self.order;
            p.christoffel = !self.no_christoffel;
        }
        p.weighting = match self.weights {
            WeightArg::Paper => Weighting::Paper,
            WeightArg::Wendland => Weighting::Wendland,
        };
        p
    }
}

#[derive(ValueEnum, Clone, Copy, Debug)]
enum SolverArg {
    Bicgstab,
    Lu,
}

#[derive(ValueEnum, Clone, Copy, Debug)]
enum EigenArg {
    None,
    Ritz,
    ShiftInvert,
}

#[derive(ValueEnum, Clone, Copy, Debug)]
enum SchemeArg {
    /// The paper's s ← s + Δt L s.
    ForwardEuler,
    /// (I − Δt L) s⁺ = s.
    BackwardEuler,
    /// (I − Δt/2 L) s⁺ = (I + Δt/2 L) s.
    CrankNicolson,
    /// exp(tL) s₀ by Krylov (no time error to speak of).
    Exact,
}

#[derive(Subcommand, Debug)]
enum Case {
    /// Heat diffusion on the unit sphere, s₀ = cos φ, exact e^{-2t} cos φ (paper §10.1).
    SphereDiffusion(SphereArgs),
    /// Mean-curvature vector κn = Δx on a sphere, torus, cylinder, circle and helix.
    Curvature(CurvArgs),
    /// Implicit diffusion on a sheet wing with filament rim and tails (Fig. 12).
    Butterfly(ButterflyArgs),
    /// Sheet reseeding under LeVeque's deformation flow and back (Fig. 15).
    SphereDeformation(super::validate_films::DeformationArgs),
    /// A film between two rings settles to the catenoid r = a cosh(z/a) (Fig. 6).
    Catenoid(super::validate_films::CatenoidArgs),
    /// A free liquid slab's edge against the 2σ-per-length pull of Taylor–Culick retraction.
    Slab(super::validate_liquid::SlabArgs),
    /// A box's long edges against Keller & Miksis's self-similar recoil of a liquid wedge.
    Wedge(super::validate_liquid::WedgeArgs),
}

/// Flags of `validate sphere-diffusion`.
#[derive(Args, Debug)]
struct SphereArgs {
    /// Target particle count (Appendix F latitude-circle sampling).
    #[arg(long, default_value_t = 30_000)]
    particles: usize,
    /// MLS support radius h (m).
    #[arg(long, default_value_t = 0.1)]
    h: Real,
    /// End time t (s).
    #[arg(long, default_value_t = 0.5)]
    t: Real,
    /// Time step of the chosen scheme (s).
    #[arg(long, default_value_t = 1e-3)]
    dt: Real,
    /// Time scheme for the total error; the spatial error always uses `exact`.
    #[arg(long, value_enum, default_value_t = SchemeArg::Exact)]
    scheme: SchemeArg,
    /// Tangential jitter of the sampling, as a fraction of the spacing (0–0.5).
    #[arg(long, default_value_t = 0.0)]
    jitter: Real,
    /// Seed of the jitter.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Linear solver of the implicit schemes: `bicgstab` (BiCGSTAB + Jacobi)
    /// or `lu` (faer sparse LU, factorised once; ~9 s for 30k particles).
    #[arg(long, value_enum, default_value_t = SolverArg::Bicgstab)]
    solver: SolverArg,
    /// Rightmost-eigenvalue estimate: `shift-invert` (45 Arnoldi steps on
    /// (I − 0.002 L)⁻¹, solves by --solver), `ritz` (converged Ritz values of
    /// L: fast, can miss unstable modes; also gives the spectral radius) or `none`.
    #[arg(long, value_enum, default_value_t = EigenArg::ShiftInvert)]
    eigen: EigenArg,
    /// Convergence mode: run these particle counts (comma separated, ≥ 3)
    /// with h scaled to keep h/Δ as in the default case, and print the observed order.
    #[arg(long, value_delimiter = ',')]
    convergence: Vec<usize>,
    #[command(flatten)]
    op: OperatorArgs,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

/// Flags of `validate curvature`.
#[derive(Args, Debug)]
struct CurvArgs {
    /// Spacings Δ (m) of the resolutions, coarse to fine (comma separated); h = 4.88 Δ.
    #[arg(long, value_delimiter = ',', default_values_t = vec![0.08, 0.04, 0.02])]
    spacings: Vec<Real>,
    #[command(flatten)]
    op: OperatorArgs,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

/// Flags of `validate butterfly`.
#[derive(Args, Debug)]
struct ButterflyArgs {
    /// Particle spacing Δ (m) of the wing (span ≈ 2 m); h = 3.5 Δ.
    #[arg(long, default_value_t = 0.02)]
    spacing: Real,
    /// Backward-Euler time step (s).
    #[arg(long, default_value_t = 0.01)]
    dt: Real,
    /// Number of steps.
    #[arg(long, default_value_t = 200)]
    steps: usize,
    /// Weight of sheet neighbours in a filament fit (§3.2.4; paper: 0.25).
    #[arg(long, default_value_t = 0.25)]
    sheet_weight_in_filament: Real,
    #[command(flatten)]
    op: OperatorArgs,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

/// Runs the chosen case.
pub fn run(a: ValidateArgs) -> Result<()> {
    match a.case {
        Case::SphereDiffusion(s) => sphere(s),
        Case::Curvature(c) => curvature(c),
        Case::Butterfly(b) => butterfly(b),
        Case::SphereDeformation(d) => super::validate_films::deformation(d),
        Case::Catenoid(c) => super::validate_films::catenoid(c),
        Case::Slab(s) => super::validate_liquid::slab(s),
        Case::Wedge(w) => super::validate_liquid::wedge(w),
    }
}

fn sphere(a: SphereArgs) -> Result<()> {
    let case = SphereDiffusion {
        particles: a.particles,
        jitter: a.jitter,
        seed: a.seed,
        t_end: a.t,
        dt: a.dt,
        scheme: match a.scheme {
            SchemeArg::ForwardEuler => Scheme::ForwardEuler,
            SchemeArg::BackwardEuler => Scheme::BackwardEuler,
            SchemeArg::CrankNicolson => Scheme::CrankNicolson,
            SchemeArg::Exact => Scheme::Exact,
        },
        mls: a.op.params(a.h),
        solver: match a.solver {
            SolverArg::Bicgstab => LinearSolver::Bicgstab,
            SolverArg::Lu => LinearSolver::SparseLu,
        },
        eigen: match a.eigen {
            EigenArg::None => EigenMethod::None,
            EigenArg::Ritz => EigenMethod::Ritz,
            EigenArg::ShiftInvert => EigenMethod::ShiftInvert,
        },
    };
    if !a.convergence.is_empty() {
        anyhow::ensure!(
            a.convergence.len() >= 3,
            "--convergence needs at least 3 particle counts, got {}",
            a.convergence.len()
        );
        let h_over = a.h / codimfx::validate::sampling::sphere_spacing_for(a.particles, 1.0);
        let c = convergence(&case, &a.convergence, h_over)
            .context("sphere-diffusion convergence study")?;
        if a.json {
            println!("{}", serde_json::to_string_pretty(&c)?);
            return Ok(());
        }
        println!(
            "sphere diffusion convergence (h/Δ = {h_over:.3}, order {}, t = {})",
            case.mls.order, a.t
        );
        println!("| particles | Δ | h | spatial max | spatial L1 | rightmost λ | s |");
        println!("|---|---|---|---|---|---|---|");
        for r in &c.runs {
            println!(
                "| {} | {:.5} | {:.4} | {:.3e} | {:.3e} | {} | {:.2} |",
                r.particles,
                r.spacing,
                r.h,
                r.spatial_max_error,
                r.spatial_l1_error,
                r.rightmost_eigenvalue
                    .map_or("-".into(), |v| format!("{v:.3e}")),
                r.seconds
            );
        }
        println!(
            "observed order (max): {:?}",
            c.observed_order_max
                .iter()
                .map(|v| format!("{v:.2}"))
                .collect::<Vec<_>>()
        );
        println!(
            "observed order (L1):  {:?}",
            c.observed_order_l1
                .iter()
                .map(|v| format!("{v:.2}"))
                .collect::<Vec<_>>()
        );
        return Ok(());
    }
    let r = case.run().context("sphere-diffusion")?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&r)?);
        return Ok(());
    }
    println!(
        "sphere diffusion (paper §10.1): ∂s/∂t = Δs on the unit sphere, s0 = cos φ, t = {}",
        a.t
    );
    println!("| quantity | value |\n|---|---|");
    println!(
        "| particles | {} (Δ = {:.5}, h = {}, {:.1} neighbours) |",
        r.particles, r.spacing, r.h, r.mean_neighbors
    );
    println!(
        "| operator | order {}, christoffel {}, weights {:?} |",
        case.mls.order, case.mls.christoffel, case.mls.weighting
    );
    println!("| spatial max error | {:.3e} |", r.spatial_max_error);
    println!("| spatial L1 error | {:.3e} |", r.spatial_l1_error);
    println!("| scheme | {:?} (dt = {}) |", r.scheme, r.dt);
    println!("| total max error | {:.3e} |", r.total_max_error);
    println!("| total L1 error | {:.3e} |", r.l1_error);
    println!("| time max error | {:.3e} |", r.time_max_error);
    if let (Some(re), Some(im)) = (r.rightmost_eigenvalue, r.rightmost_eigenvalue_im) {
        println!("| rightmost eigenvalue | {re:.3e} {im:+.3e}i |");
    }
    if let Some(rho) = r.spectral_radius {
        println!(
            "| spectral radius (Ritz) | {rho:.4e} (forward Euler needs dt < {:.3e}) |",
            2.0 / rho
        );
    }
    println!(
        "| fits | {} full order, {} lowered, {} boundary rows, {} without row ({} isolated) |",
        r.fit_stats.full_order,
        r.fit_stats.lowered_order,
        r.fit_stats.boundary,
        r.fit_stats.no_row,
        r.fit_stats.isolated
    );
    println!("| max relative row sum | {:.1e} |", r.max_relative_row_sum);
    println!(
        "| seconds | {:.2} (operator {:.2}) |",
        r.seconds, r.seconds_operator
    );
    Ok(())
}

fn curvature(a: CurvArgs) -> Result<()> {
    anyhow::ensure!(
        a.spacings.len() >= 3,
        "--spacings needs at least 3 values, got {}",
        a.spacings.len()
    );
    let base = a.op.params(1.0);
    let mut all = Vec::new();
    for shape in CurvatureShape::ALL {
        all.push(
            curvature_study(shape, &a.spacings, 4.88, &base)
                .with_context(|| format!("curvature on {shape:?}"))?,
        );
    }
    if a.json {
        println!("{}", serde_json::to_string_pretty(&all)?);
        return Ok(());
    }
    println!(
        "curvature vector κn = Δx: relative error |Δx − κn| / |κ| (max and mean over particles)"
    );
    println!("| shape | particles | Δ | max rel error | mean rel error | order (max) |");
    println!("|---|---|---|---|---|---|");
    for s in &all {
        for (i, r) in s.runs.iter().enumerate() {
            let ord = if i == 0 {
                "-".to_string()
            } else {
                format!("{:.2}", s.observed_order_max[i - 1])
            };
            println!(
                "| {:?} | {} | {:.4} | {:.3e} | {:.3e} | {} |",
                s.shape, r.particles, r.spacing, r.max_rel_error, r.mean_rel_error, ord
            );
        }
    }
    Ok(())
}

fn butterfly(a: ButterflyArgs) -> Result<()> {
    let mut mls = a.op.params(3.5 * a.spacing);
    mls.sheet_weight_in_filament = a.sheet_weight_in_filament;
    let r = Butterfly {
        spacing: a.spacing,
        dt: a.dt,
        steps: a.steps,
        mls,
    }
    .run()
    .context("butterfly")?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&r)?);
        return Ok(());
    }
    println!("butterfly: backward-Euler diffusion on a sheet wing with filament rim and tails");
    println!("| quantity | value |\n|---|---|");
    println!(
        "| sheet / filament particles | {} / {} |",
        r.sheet_particles, r.filament_particles
    );
    println!("| steps × dt | {} × {} |", r.steps, r.dt);
    println!(
        "| total heat, start → end | {:.6} → {:.6} (drift {:+.3e}) |",
        r.heat_start, r.heat_end, r.heat_drift
    );
    println!(
        "| min over run / max at end | {:.4e} / {:.4e} (initial range [0, 1]) |",
        r.min_all, r.max_end
    );
    println!(
        "| rightmost eigenvalue of L | {:.3e} |",
        r.rightmost_eigenvalue
    );
    println!(
        "| max principle violation | {:.3e} |",
        r.max_principle_violation
    );
    println!(
        "| fraction of particles heated (> 1e-3) | {:.3} |",
        r.heated_fraction
    );
    println!("| heat on filaments at end | {:.4e} |", r.filament_heat_end);
    println!(
        "| fits | {} full, {} lowered, {} boundary rows, {} no row |",
        r.fit_stats.full_order, r.fit_stats.lowered_order, r.fit_stats.boundary, r.fit_stats.no_row
    );
    println!("| seconds | {:.2} |", r.seconds);
    Ok(())
}
