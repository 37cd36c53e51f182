//! Kernel-level TDD for a kernel not part of vxgi (WGSL beside this file): typed bindings, tolerance,
//! mirror, generated cases, verify. `cargo run --example tdd_own_kernel` exits 1 on a mismatch.
use vxgi::harness::{bindings, *};

bindings! {
    pub struct Io {
        inputs: { rgb: Vec<[f32; 4]> }
        // 3 products, 2 sums of non-negative terms, each rounded or fused: 3 ULP; flushing: < 1e-37.
        outputs: { luma: Vec<f32> => Tolerance::Ulp { ulps: 3, abs_floor: 1e-37 } }
    }
}
pub static DECL: KernelDecl = KernelDecl {
    name: "luminance",
    wgsl_path: "examples/tdd_own_kernel.wgsl",
    wgsl: include_str!("tdd_own_kernel.wgsl"),
    includes: &[],
    entry: "main",
    inputs: Io::INPUTS,
    outputs: Io::OUTPUTS,
    dispatch: DispatchRule::PerElement { binding: "luma" },
    mirror: "tdd_own_kernel::luminance",
    summary: "Rec. 709 luminance of linear RGB",
};

/// The mirror: the WGSL's arithmetic in its order.
pub fn luminance(c: &[f32; 4]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// The kernel under test: `DECL`, or another declaration of its interface (a changed WGSL).
pub struct Luminance(pub &'static KernelDecl);

impl Kernel for Luminance {
    fn decl(&self) -> &'static KernelDecl {
        self.0
    }
    fn case(&self, shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let mut next = generated_floats(seed ^ index as u64, &[0.0, 1e-45, 1e30, 0.5, 1.0]);
        let n = [1, 63, 64, 65, 10_000][index % 5];
        let rgb = (0..n).map(|_| [next(), next(), next(), 0.0]).collect();
        let (luma, label) = (vec![0.0; n], format!("{n} px"));
        let io = Io { rgb, luma };
        self.0.case_of(shader, ctx, &io, n as u64, label, seed)
    }
    fn mirror(&self, _: &Case, data: &Resources, _: FloatMode) -> MirrorOutputs {
        let mut io = Io::read(data);
        io.luma = io.rgb.iter().map(luminance).collect();
        io.outputs()
    }
}

fn main() -> anyhow::Result<()> {
    let (ctx, opts) = (GpuContext::new()?, VerifyOptions::cases(10));
    let rep = verify(&ctx, &Luminance(&DECL), &opts, &mut |_| {})?;
    let rep = rep.check().map_err(anyhow::Error::msg)?;
    let (n, ulp) = (rep.elements, rep.max_ulp);
    println!("luminance: {n} elements, max {ulp} ULP");
    Ok(())
}
