//! The `anybox` command-line tool.

fn main() {
    println!("anybox {}", env!("CARGO_PKG_VERSION"));
}
