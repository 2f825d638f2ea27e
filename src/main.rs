//! `physskin`: the command line. Everything it does lives in the library, behind
//! [`physskin::cli::main`].

fn main() -> std::process::ExitCode {
    physskin::cli::main()
}
