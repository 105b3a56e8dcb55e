//! The whole workbench (`view`, `bench`, `report`, `bench --suite stiff`, ...) with `fixed-pcf`
//! beside the built-in techniques.

fn main() -> std::process::ExitCode {
    softshadow_workbench::main_with(vec![custom_technique::info()])
}
