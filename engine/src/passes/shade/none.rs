//! Technique `none` (shaders-glsl/shade/none): unshadowed lighting. Environment: diffuse from the
//! shared irradiance grid, glossy from the shared SG-prefiltered environment maps. Spherical lights:
//! each added unshadowed (shaders-glsl/shade/lights.glsl). The baseline every shadowing technique is
//! compared with, and the furnace reference (ρL for a Lambertian plane).

use super::{Reads, ShadeInputs, ShadeTarget, TargetPipelines, Technique, TechniqueEntry, Tolerances};
use crate::gpu::{Binding, Gpu, Recorder, Result};

pub const ENTRY: TechniqueEntry = TechniqueEntry {
    name: "none",
    summary: "unshadowed: irradiance grid + SG-prefiltered environment, spherical lights in closed form",
    options: &[super::env_lights_option("off")],
    reads: Reads { lights: true, blockers: false, thin: false, geometry: false, env_lights: false },
    // The irradiance grid is exact up to bilinear interpolation of a smooth function: the furnace is
    // flat to f32 rounding.
    tolerances: Tolerances { furnace: 1e-3, unoccluded_vs_none: 0.0, one_sphere: None, one_plane: None, samples: 0 },
    create: |gpu, _| Ok(Box::new(NoShadows::new(gpu)?)),
};

pub struct NoShadows {
    pipelines: TargetPipelines,
}

impl NoShadows {
    pub fn new(gpu: &Gpu) -> Result<Self> {
        Ok(Self { pipelines: TargetPipelines::new(gpu, "none")? })
    }
}

impl Technique for NoShadows {
    fn name(&self) -> &'static str {
        "none"
    }

    fn prepare(&mut self, _gpu: &Gpu, _inputs: &ShadeInputs) -> Result<()> {
        // Everything it reads is a shared scene resource.
        Ok(())
    }

    fn record(&self, rec: &mut Recorder, inputs: &ShadeInputs, target: ShadeTarget) -> Result<()> {
        let env = inputs.environment;
        self.pipelines.record(
            rec,
            "none",
            inputs,
            target,
            &[
                Binding::sampled("irradiance_map", &env.irradiance),
                Binding::sampled("prefiltered_env", &env.prefiltered),
                Binding::buffer("Lights", &inputs.lights()?.buffer),
            ],
        )
    }

    fn destroy(self: Box<Self>, gpu: &Gpu) {
        self.pipelines.destroy(gpu);
    }
}
