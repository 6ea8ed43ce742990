//! Technique `template` (shaders-glsl/shade/template): the unshadowed diffuse term ρ/π E(n) from the
//! shared irradiance grid. A starting point for a new technique (docs/technique-template/README.md).

use super::{Reads, ShadeInputs, ShadeTarget, TargetPipelines, Technique, TechniqueEntry, Tolerances};
use crate::gpu::{Binding, Gpu, Recorder, Result};
use crate::options::{Kind, OptionSpec};

pub const OPTIONS: &[OptionSpec] = &[OptionSpec {
    key: "gain",
    aliases: &[],
    kind: Kind::closed(0.0, 10.0),
    default: Some("1"),
    help: "a factor on the result (an example option)",
}];

pub const ENTRY: TechniqueEntry = TechniqueEntry {
    name: "template",
    summary: "template: unshadowed diffuse from the irradiance grid",
    options: OPTIONS,
    // What it reads beyond frame, materials and environment.
    reads: Reads { lights: false, blockers: false, thin: false, geometry: false, env_lights: false },
    // It ignores specular and lights, so it equals `none` only on diffuse scenes without lights.
    tolerances: Tolerances { furnace: 1e-3, unoccluded_vs_none: 1e-5, one_sphere: None, one_plane: None, samples: 0 },
    create: |gpu, o| {
        Ok(Box::new(Template { pipelines: TargetPipelines::new(gpu, "template")?, gain: o.float("gain") }))
    },
};

pub struct Template {
    pipelines: TargetPipelines,
    gain: f64,
}

impl Technique for Template {
    fn name(&self) -> &'static str {
        ENTRY.name
    }

    fn prepare(&mut self, _gpu: &Gpu, _inputs: &ShadeInputs) -> Result<()> {
        // Derive here, once per scene, only what this technique reads (fits, tables, buffers).
        Ok(())
    }

    fn record(&self, rec: &mut Recorder, inputs: &ShadeInputs, target: ShadeTarget) -> Result<()> {
        let push = [self.gain as f32];
        self.pipelines.record_with_push(
            rec,
            ENTRY.name,
            inputs,
            target,
            &[Binding::sampled("irradiance_map", &inputs.environment.irradiance)],
            bytemuck::cast_slice(&push),
        )
    }

    fn destroy(self: Box<Self>, gpu: &Gpu) {
        self.pipelines.destroy(gpu);
    }
}
