//! `codimfx bench accuracy`: run time against error of the coupled solver
//! (paper §7) on the l = 2 oscillation of a droplet without gravity
//! (R = 0.0128 m, σ = 0.03 N/m, elongation 5 %): the measured period
//! against Rayleigh's 2π/ω, ω² = 8σ/(ρR³), at several resolutions R/Δx and
//! two substeps, with the wall time of each run. `--plot FILE.png` draws
//! |period error| against wall time (log–log, one series per substep).
use super::operators::{plot, Point};
use anyhow::Result;
use clap::Args;
use codimfx::coupling::{BandVelocity, FaceMass, LayerTension};
use codimfx::validate::droplet::{oscillate, oscillate_period, DropletCase};
use codimfx::Real;
use std::path::PathBuf;

/// Arguments of `codimfx bench accuracy`.
#[derive(Args, Debug)]
pub struct AccuracyArgs {
    /// Resolutions R/Δx.
    #[arg(long, value_delimiter = ',', default_values_t = vec![3.0, 4.0, 6.0])]
    cells: Vec<Real>,
    /// Substeps Δt (s).
    #[arg(long, value_delimiter = ',', default_values_t = vec![0.01, 0.005])]
    dt: Vec<Real>,
    /// Level-set radius of the volume particles relative to Δx.
    #[arg(long, default_value_t = 1.0)]
    surface_radius: Real,
    /// Mass of the constraint faces: `balanced` (the liquid ends at the
    /// sheet layer, moved so that the grid carries the volume particles'
    /// mass), `sheet` (the liquid ends at the sheet layer) or `level-set`.
    #[arg(long, value_enum, default_value_t = FaceMassArg::Balanced)]
    face_mass: FaceMassArg,
    /// Velocity of the constraint faces: `extrapolated` (the sheet's
    /// velocity carried to the face with its gradient) or `sheet` (the
    /// sheet's own).
    #[arg(long, value_enum, default_value_t = BandArg::Extrapolated)]
    band: BandArg,
    /// Smallest mass fraction of a constraint face (`coupling.mass_floor`).
    #[arg(long, default_value_t = codimfx::coupling::system::MASS_FLOOR)]
    mass_floor: Real,
    /// How P2G reads the particles at the surface (`solver.velocity_fit`).
    #[arg(long, value_enum, default_value_t = FitArg::Mean)]
    velocity_fit: FitArg,
    /// Solve the coupled system with λ eliminated (the Schur form).
    #[arg(long)]
    schur: bool,
    /// How the surface layer carries its tension (`coupling.layer`).
    #[arg(long, value_enum, default_value_t = LayerArg::Coupled)]
    layer: LayerArg,
    /// Implicit weight θ of the tension (`coupling.tension_theta`, [0.5, 1]).
    #[arg(long, default_value_t = codimfx::coupling::system::TENSION_THETA)]
    tension_theta: Real,
    /// Run each case a whole period and print the swing ratio (the
    /// numerical damping: 1 without any, 0.991 for water at this size).
    #[arg(long)]
    damping: bool,
    /// Write the error-against-time chart to this PNG.
    #[arg(long)]
    plot: Option<PathBuf>,
}

/// `--face-mass`.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum FaceMassArg {
    /// The liquid ends at the sheet layer, moved so that the grid carries
    /// the volume particles' mass.
    Balanced,
    /// The liquid ends at the sheet layer.
    Sheet,
    /// The pressure solve's level set.
    LevelSet,
}

/// `--layer` (`coupling.layer`).
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum LayerArg {
    /// Through the constraint faces of eq. (24).
    Coupled,
    /// A ghost-fluid pressure jump at the free surface.
    Jump,
    /// The liquid ends at the layer, which closes the cells it crosses.
    Cut,
}

impl From<LayerArg> for LayerTension {
    fn from(a: LayerArg) -> LayerTension {
        match a {
            LayerArg::Coupled => LayerTension::Coupled,
            LayerArg::Jump => LayerTension::Jump,
            LayerArg::Cut => LayerTension::Cut,
        }
    }
}

/// `--velocity-fit`.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum FitArg {
    /// The weighted mean.
    Mean,
    /// The weighted least-squares linear fit.
    Linear,
}

/// `--band`.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum BandArg {
    /// The sheet's own velocity.
    Sheet,
    /// Carried to the face with the liquid's velocity gradient.
    Extrapolated,
    /// As `extrapolated`, and the faces' own velocity extended from inside
    /// the liquid.
    Extended,
}

/// Runs the benchmark and prints a markdown table.
pub fn run(a: AccuracyArgs) -> Result<()> {
    if !(0.5..=1.0).contains(&a.tension_theta) {
        anyhow::bail!(
            "--tension-theta must be in [0.5, 1], got {}",
            a.tension_theta
        );
    }
    println!("threads: {}\n", rayon::current_num_threads());
    println!(
        "## l = 2 droplet oscillation (R = 0.0128 m, σ = 0.03 N/m, e = 0.05, surface radius {} Δx, face mass {:?}, mass floor {}, band {:?}, layer {:?}, tension θ {}, velocity fit {:?})\n",
        a.surface_radius, a.face_mass, a.mass_floor, a.band, a.layer, a.tension_theta, a.velocity_fit
    );
    if a.damping {
        println!("| R/Δx | Δt (s) | particles | substeps | period (s) | Rayleigh (s) | error | swing ratio | wall (s) |");
        println!("|---|---|---|---|---|---|---|---|---|");
    } else {
        println!("| R/Δx | Δt (s) | particles | substeps | period (s) | Rayleigh (s) | error | wall (s) |");
        println!("|---|---|---|---|---|---|---|---|");
    }
    let mut points = Vec::new();
    for (series, &dt) in a.dt.iter().enumerate() {
        for &cells in &a.cells {
            let case = DropletCase {
                surface_radius: a.surface_radius,
                mass_floor: a.mass_floor,
                tension_theta: a.tension_theta,
                layer: a.layer.into(),
                face_mass: match a.face_mass {
                    FaceMassArg::Balanced => FaceMass::Balanced,
                    FaceMassArg::Sheet => FaceMass::Sheet,
                    FaceMassArg::LevelSet => FaceMass::LevelSet,
                },
                band: match a.band {
                    BandArg::Sheet => BandVelocity::Sheet,
                    BandArg::Extrapolated => BandVelocity::Extrapolated,
                    BandArg::Extended => BandVelocity::Extended,
                },
                method: if a.schur {
                    codimfx::coupling::Method::Schur
                } else {
                    codimfx::coupling::Method::Monolithic
                },
                velocity_fit: match a.velocity_fit {
                    FitArg::Mean => codimfx::grid::VelocityFit::Mean,
                    FitArg::Linear => codimfx::grid::VelocityFit::Linear,
                },
                elongation: 0.05,
                ..DropletCase::paper(cells)
            };
            let o = if a.damping {
                oscillate_period(&case, dt)?
            } else {
                oscillate(&case, dt)?
            };
            println!(
                "| {cells} | {dt} | {} | {} | {:.4} | {:.4} | {:+.1} % |{} {:.1} |",
                o.particles,
                o.steps,
                o.period,
                o.rayleigh,
                100.0 * o.error,
                o.swing_ratio
                    .map_or(String::new(), |r| format!(" {r:.3} |")),
                o.wall_s
            );
            points.push(Point {
                series,
                seconds: o.wall_s,
                error: o.error.abs(),
            });
        }
    }
    if let Some(path) = &a.plot {
        let colors = [[200, 40, 40], [40, 80, 200], [40, 160, 60], [160, 100, 20]];
        plot(path, &points, &colors[..a.dt.len().min(4)])?;
        println!(
            "\nplot: {} (x: wall seconds, y: |period error|, log–log)",
            path.display()
        );
        for (i, dt) in a.dt.iter().enumerate().take(4) {
            println!("  series Δt = {dt} s: rgb{:?}", colors[i]);
        }
    }
    Ok(())
}
