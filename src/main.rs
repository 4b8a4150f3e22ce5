fn main() {
    std::process::exit(scatterbake::cli::main());
}
