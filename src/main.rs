//! The `mvscope` binary: natively the command line (`src/cli/`), in the browser the viewer's
//! web page (`mvscope::viewer::web`, built by scripts/build-web.sh).

#[cfg(not(target_arch = "wasm32"))]
mod cli;

#[cfg(not(target_arch = "wasm32"))]
fn main() -> std::process::ExitCode {
    cli::main()
}

#[cfg(target_arch = "wasm32")]
fn main() {
    mvscope::viewer::web::start();
}
