//! One file per subcommand: each defines its clap `…Args` and a `run`.
pub mod bench;
pub mod outline;
pub mod preview;
pub mod sim;
pub mod surface;
pub mod validate;
pub mod validate_films;
pub mod validate_liquid;
