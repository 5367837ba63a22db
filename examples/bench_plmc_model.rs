//! Writes the synthetic PLM-C model of `benches/btf_eval.rs` (UBO2003 directions, 256 random
//! clusters per view and channel, a random cluster index per texel: the cache behaviour of a
//! real model at its worst) as a `.plmc` file, the input of `scripts/bench_python_eval.py`:
//!
//! `cargo run --release --example bench_plmc_model -- 256 /tmp/bench256.plmc`

use btfpt::model::{ModelKind, codec};
use std::path::PathBuf;
#[path = "../benches/common/btf_scene.rs"]
#[allow(dead_code)]
mod btf_scene;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [size, out] = args.as_slice() else {
        anyhow::bail!("usage: bench_plmc_model SIZE OUT.plmc");
    };
    let size: usize = size
        .parse()
        .map_err(|e| anyhow::anyhow!("SIZE {size}: {e}"))?;
    let out = PathBuf::from(out);
    let model = btf_scene::model_sized(ModelKind::PlmC, size);
    codec::write(&out, &model)?;
    println!(
        "{}: {size}×{size} texels, PLM-C, 256 clusters",
        out.display()
    );
    Ok(())
}
