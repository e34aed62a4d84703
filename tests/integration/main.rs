//! lash's integration tests: one module per concern (its file's first lines say what it
//! checks), all in one test binary, so the library is linked once and the two cores share
//! every test instead of running twenty binaries one after another.

mod bench_models;
#[cfg(all(feature = "cli", feature = "plot", feature = "peers"))]
mod cli;
mod contact;
mod dae_api;
mod diagnose;
mod diagnose_suite;
mod explicit;
#[cfg(all(feature = "cli", feature = "plot", feature = "peers"))]
mod linear_axis;
#[cfg(all(feature = "cli", feature = "plot", feature = "peers"))]
mod model_file;
mod mr2120;
mod mr2120_lumped;
mod mr2120_model_files;
mod mr2120_truth;
mod multibody_jacobian;
mod multibody_layer;
mod multibody_pendulum;
mod peers_diffsol;
mod scratch;
mod transmission;
#[cfg(all(feature = "cli", feature = "plot", feature = "peers"))]
mod urdf;
mod validation;
