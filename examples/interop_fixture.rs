//! Writes the interop fixtures (see `tests/support/fixture.rs`) into a directory:
//! `cargo run --example interop_fixture -- OUT_DIR`. Used by `scripts/interop/run.sh`.

#[path = "../tests/support/fixture.rs"]
mod fixture;

fn main() -> anyhow::Result<()> {
    let dir = std::env::args_os()
        .nth(1)
        .map(std::path::PathBuf::from)
        .ok_or_else(|| anyhow::anyhow!("usage: interop_fixture OUT_DIR"))?;
    std::fs::create_dir_all(&dir)?;
    fixture::write_all(&dir)?;
    println!("wrote {}", dir.display());
    Ok(())
}
