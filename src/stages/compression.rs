//! `compression`: how far the Lubachevsky-Stillinger compression of the
//! initial state gets towards `phi` at a compression rate and N, without
//! failing where it jams (`simulate` refuses such a spec): one row,
//! `phi_reached, jammed, compress_time, collisions_per_disk`.

use anyhow::Result;
use serde_json::Value;

use crate::pipeline::registry::typed;
use crate::pipeline::{Artifact, Output, StageCtx, StageKind};
use crate::sim::{SimConfig, initial_state};
use crate::table::{f64_batch, to_parquet_bytes};

pub struct Compression;

impl StageKind for Compression {
    type Params = SimConfig;
    fn name(&self) -> &str {
        "compression"
    }
    fn describe(&self) -> &str {
        "the packing fraction a Lubachevsky-Stillinger compression reaches towards `phi` (one row: phi_reached, jammed, compress_time, collisions_per_disk); used as an experiment's kind"
    }
    fn details(&self) -> String {
        "  parameters: the SimConfig fields that shape the start (n, phi, compression_rate, radius_ratio, fraction_large, seed, ...)\n  example (experiments/stability_compression.yaml):\n    kind: compression\n    params: {phi: 0.85}\n    profiles: {ci: {grid: {n: [100, 200], compression_rate: [0.1, 0.01]}, replicas: 1}}".into()
    }
    fn modules(&self) -> &[&str] {
        &[file!()]
    }
    fn parse(&self, params: &Value) -> Result<SimConfig> {
        let cfg: SimConfig = typed("compression", params)?;
        cfg.validate()?;
        Ok(cfg)
    }
    fn resolved(&self, cfg: &SimConfig) -> Option<serde_json::Map<String, Value>> {
        super::simulate::resolved(cfg).ok()
    }
    fn run(&self, ctx: &StageCtx, cfg: &SimConfig, _inputs: &[Artifact]) -> Result<Output> {
        let c = initial_state::compression_limit(cfg, &|p: crate::sim::Progress| {
            ctx.progress(p.time, p.end, "compressing")
        })?;
        ctx.log(format!(
            "n = {}, compression_rate = {}: phi = {:.4} reached{}",
            cfg.n,
            cfg.compression_rate,
            c.reached,
            if c.jammed { " (jammed)" } else { "" }
        ));
        let b = f64_batch(&[
            ("phi_reached", vec![c.reached]),
            ("jammed", vec![f64::from(u8::from(c.jammed))]),
            ("compress_time", vec![c.time]),
            (
                "collisions_per_disk",
                vec![c.collisions as f64 / cfg.n as f64],
            ),
        ])?;
        Ok(Output::single("parquet", to_parquet_bytes(&[b], &[])?))
    }
}
