fn main() -> std::process::ExitCode {
    lumen::cli::main()
}
