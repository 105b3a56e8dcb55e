//! `workbench`: the soft-shadow workbench over the built-in techniques (the command line is
//! [`softshadow_workbench::main_with`]).

fn main() -> std::process::ExitCode {
    softshadow_workbench::main_with(Vec::new())
}
