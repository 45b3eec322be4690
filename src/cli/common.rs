//! Arguments shared by every command that reads a mesh.

use clap::Args;

use crate::mesh::{LoadOptions, Mesh, NormalWeighting};
use crate::patch::{PatchTable, Scheme, SchemeOptions};

#[derive(Args, Clone, Debug)]
pub struct InputArgs {
    /// Mesh file (.obj, or .pn point-normal) or built-in mesh: sphere320, torus200, icosphere:L,
    /// torus:NxM[:analytic|:averaged].
    pub mesh: String,
    /// Surface scheme.
    #[arg(long, value_enum, default_value = "g1")]
    pub scheme: Scheme,
    /// Weighting of face normals where vertex normals are estimated.
    #[arg(long, value_enum, default_value = "angle")]
    pub normals: NormalWeighting,
    /// Estimate normals even where the file gives them.
    #[arg(long)]
    pub recompute_normals: bool,
    /// Mark edges whose dihedral angle exceeds DEG degrees as creases and estimate normals
    /// per smoothing group (replaces any normals the file gives).
    #[arg(long, value_name = "DEG")]
    pub crease_angle: Option<f64>,
    /// Phong tessellation's shape factor α.
    #[arg(long, default_value_t = 0.75)]
    pub phong_alpha: f64,
}

impl InputArgs {
    /// Defaults for a built-in mesh (the default run).
    pub fn builtin(mesh: &str) -> InputArgs {
        InputArgs {
            mesh: mesh.into(),
            scheme: Scheme::G1,
            normals: NormalWeighting::Angle,
            recompute_normals: false,
            crease_angle: None,
            phong_alpha: 0.75,
        }
    }

    pub fn load_options(&self) -> LoadOptions {
        LoadOptions {
            weighting: self.normals,
            recompute_normals: self.recompute_normals,
            crease_angle: self.crease_angle,
        }
    }

    pub fn scheme_options(&self) -> SchemeOptions {
        SchemeOptions {
            phong_alpha: self.phong_alpha,
        }
    }

    /// Loads the mesh and builds the scheme's patch table.
    pub fn load(&self) -> anyhow::Result<(Mesh, PatchTable)> {
        let mesh = Mesh::load(&self.mesh, &self.load_options())?;
        let table = PatchTable::build(&mesh, self.scheme, &self.scheme_options())?;
        Ok((mesh, table))
    }
}

/// Which evaluator runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Backend {
    /// The f64 CPU reference (rayon, all threads).
    Cpu,
    /// WGSL compute shaders on a Vulkan adapter; fails when there is none.
    Gpu,
    /// The GPU, falling back to the CPU (with a message on stderr) when it cannot run.
    Auto,
}

/// Backend arguments shared by every command that evaluates patches.
#[derive(Args, Clone, Debug)]
pub struct BackendArgs {
    /// Evaluation backend.
    #[arg(long, value_enum, default_value = "auto")]
    pub backend: Backend,
    /// GPU working precision (f64 needs an adapter with SHADER_F64; the CPU is always
    /// f64). Default: f64 for statistics (stats, compare, the default run), f32 for
    /// geometry (tessellate).
    #[arg(long, value_enum)]
    pub precision: Option<crate::gpu::Precision>,
    /// Say nothing on stderr about the adapter or the fallback (set by `--quiet`).
    #[arg(skip)]
    pub quiet: bool,
}

impl Default for BackendArgs {
    fn default() -> Self {
        BackendArgs {
            backend: Backend::Auto,
            precision: None,
            quiet: false,
        }
    }
}

impl BackendArgs {
    /// The evaluator asked for, with `default_precision` on the GPU unless `--precision`
    /// was given. The GPU is opened on the first evaluation (so input errors come first and
    /// alone); then the GPU backend names its adapter on stderr, and `auto` says on stderr
    /// when it falls back to the CPU, and why.
    pub fn evaluator(
        &self,
        default_precision: crate::gpu::Precision,
    ) -> anyhow::Result<Box<dyn crate::eval::Evaluator>> {
        Ok(match self.backend {
            Backend::Cpu => Box::new(crate::eval::cpu::CpuEvaluator::default()),
            backend => Box::new(LazyGpu {
                backend,
                precision: self.precision.unwrap_or(default_precision),
                quiet: self.quiet,
                inner: std::cell::OnceCell::new(),
            }),
        })
    }
}

/// The GPU (or, for `auto`, the CPU fallback), opened on first use.
struct LazyGpu {
    backend: Backend,
    precision: crate::gpu::Precision,
    quiet: bool,
    inner: std::cell::OnceCell<Box<dyn crate::eval::Evaluator>>,
}

impl LazyGpu {
    fn open(&self) -> crate::Result<Box<dyn crate::eval::Evaluator>> {
        use crate::eval::cpu::CpuEvaluator;
        use crate::eval::gpu::GpuEvaluator;
        use crate::gpu::GpuContext;
        let gpu = || -> crate::Result<GpuEvaluator> {
            let ctx = GpuContext::shared()?;
            let ev = GpuEvaluator::new(ctx.clone(), self.precision)?;
            if !self.quiet {
                eprintln!("gpu: {} ({})", ctx.describe(), self.precision);
            }
            Ok(ev)
        };
        Ok(match (self.backend, gpu()) {
            (_, Ok(ev)) => Box::new(ev),
            (Backend::Auto, Err(e)) => {
                if !self.quiet {
                    eprintln!("note: {e}; falling back to the CPU backend (f64)");
                }
                Box::new(CpuEvaluator::default())
            }
            (_, Err(e)) => return Err(e),
        })
    }

    fn get(&self) -> crate::Result<&dyn crate::eval::Evaluator> {
        if self.inner.get().is_none() {
            let ev = self.open()?;
            let _ = self.inner.set(ev);
        }
        Ok(self.inner.get().expect("set above").as_ref())
    }
}

impl crate::eval::Evaluator for LazyGpu {
    fn describe(&self) -> String {
        match self.get() {
            Ok(ev) => ev.describe(),
            Err(e) => format!("gpu unavailable ({e})"),
        }
    }

    fn evaluate(
        &self,
        table: &crate::patch::PatchTable,
        pattern: &crate::eval::Pattern,
        sink: &mut dyn FnMut(crate::eval::Chunk<'_>) -> crate::Result<()>,
    ) -> crate::Result<()> {
        self.get()?.evaluate(table, pattern, sink)
    }

    fn evaluate_f32(
        &self,
        table: &crate::patch::PatchTable,
        pattern: &crate::eval::Pattern,
        sink: &mut dyn FnMut(crate::eval::ChunkF32<'_>) -> crate::Result<()>,
    ) -> crate::Result<()> {
        self.get()?.evaluate_f32(table, pattern, sink)
    }
}
