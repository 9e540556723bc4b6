//! Where a command finds the specs and the cache: `--root` and `--store`,
//! shared by every command that reads a project.

use std::path::PathBuf;

use clap::Args;

use crate::pipeline::Workspace;

/// Where the specs and the cache are.
#[derive(Args, Debug, Clone)]
pub struct RootArgs {
    /// Project directory holding experiments/ and pipelines/; results/ and the
    /// cache (.repro/store) are written beside them. Default: $REPRO_ROOT, else
    /// the current directory.
    #[arg(long, value_name = "DIR")]
    pub root: Option<PathBuf>,
    /// The cache directory (default: ROOT/.repro/store). With `--executor slurm`
    /// it must be on a filesystem the compute nodes share.
    #[arg(long, value_name = "PATH")]
    pub store: Option<PathBuf>,
}

impl RootArgs {
    pub(crate) fn workspace(&self) -> Workspace {
        let root = self
            .root
            .clone()
            .or_else(|| std::env::var_os("REPRO_ROOT").map(PathBuf::from))
            .unwrap_or_else(|| PathBuf::from("."));
        let mut ws = Workspace::new(&root);
        if let Some(s) = &self.store {
            ws.store = s.clone();
        }
        ws
    }
}
