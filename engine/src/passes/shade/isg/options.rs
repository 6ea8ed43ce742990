//! The options of technique `isg` (`--technique isg:key=value,...`): the schema the registry parses
//! with ([`OPTIONS`]) and the typed [`IsgOptions`] the technique and its f64 twin read.

use crate::options::{Kind, OptionSpec, Options};

/// Which ISG evaluator computes Ŝ at patch corners.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Evaluator {
    /// Our table (engine-math `IsgLut`, product of tabulated marginals): max error ≤ 0.005 for λ ∈ [1e-2, 1e5].
    Table,
    /// The paper's product of two sigmoids with the appendix quartics.
    Paper,
}

/// How the diffuse term is formed from the K visible lobe integrals.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Diffuse {
    /// ρ/π Σ_k μ_k ∫ G_k G_cos V (paper Eq. 5): carries the SG representation error of the lighting
    /// and of the cosine (the L2-fitted cosine SG integrates to 1.083 π, not π).
    Sg,
    /// ρ/π E(n) · Σ_k μ_k ∫ G_k G_cos V / Σ_k μ_k ∫ G_k G_cos: the exact irradiance E(n) (the
    /// irradiance map of technique `none`) times the lobes' visibility ratio, like the paper's Eq. 9
    /// for specular. Unoccluded points equal `none` exactly.
    Ratio,
    /// ρ/π (E(n) − Σ_occluded L̄_p C_p): one P × P grid over the hemisphere above n; the occluded
    /// patches' light is read from the prefiltered environment (filter matched to the patch width)
    /// times each patch's exact cosine-weighted solid angle. No SG represents the lighting or the
    /// cosine; ISG's patches, BVH traversal and self-shadowing rules decide what is occluded.
    Map,
}

/// The technique's parameters (see the module docs for their option names).
#[derive(Clone, Debug, PartialEq)]
pub struct IsgOptions {
    pub k: usize,
    pub side: usize,
    pub epsilon: f64,
    pub node_threshold: f64,
    pub evaluator: Evaluator,
    pub diffuse: Diffuse,
    /// Coordinate-descent rounds refining the greedy environment fit (0: greedy only).
    pub refine: usize,
    /// The counter variant of the shader (the cost model): 0 radiance, 1 and 2 the work counts
    /// (shaders-glsl/common/isg_visibility.glsl) instead of radiance.
    pub counters: u32,
    /// The blocker tiles (`tiles`, `tile_cap`).
    pub tiles: crate::passes::shade::tiles::TileOptions,
}

impl Default for IsgOptions {
    fn default() -> Self {
        Self {
            k: 10,
            side: 32,
            epsilon: 0.01,
            node_threshold: 1.0,
            evaluator: Evaluator::Table,
            diffuse: Diffuse::Map,
            refine: REFINE_ROUNDS,
            counters: 0,
            tiles: Default::default(),
        }
    }
}

/// Coordinate-descent rounds refining the greedy environment fit (engine-math `refine_envmap_sgs`).
pub const REFINE_ROUNDS: usize = 6;

/// The schema of `isg`'s options (also `--help`, the viewer, the report sweep and docs/techniques/isg.md).
pub const OPTIONS: &[OptionSpec] = &[
    OptionSpec {
        key: "diffuse",
        aliases: &[],
        kind: Kind::Choice(&["map", "ratio", "sg"]),
        default: Some("map"),
        help: "diffuse visibility: map (hemisphere patch grid weighted by the prefiltered light; ours), ratio (E(n) times the K lobes' visibility ratio) or sg (paper Eq. 5)",
    },
    OptionSpec {
        key: "patches",
        aliases: &[],
        kind: Kind::Int { min: 1, max: 32 },
        default: Some("32"),
        help: "patches per side P of every patch grid (P² patches; the paper uses 100 to 400 per lobe)",
    },
    OptionSpec {
        key: "eps",
        aliases: &["epsilon"],
        kind: Kind::Float { min: 0.0, max: 1.0, min_open: true, max_open: true },
        default: Some("0.01"),
        help: "limiting-angle threshold ε of a lobe's grid: exp(λ(cos Γ − 1)) = ε",
    },
    OptionSpec {
        key: "threshold",
        aliases: &[],
        kind: Kind::closed(0.0, f64::INFINITY),
        default: Some("1"),
        help: "BVH nodes narrower than this many patch widths are taken whole (0: open every node)",
    },
    OptionSpec {
        key: "evaluator",
        aliases: &[],
        kind: Kind::Choice(&["table", "paper"]),
        default: Some("table"),
        help: "Ŝ at patch corners: table (ours, max error ≤ 0.005) or paper (the sigmoid fit of the appendix)",
    },
    OptionSpec {
        key: "K",
        aliases: &["k"],
        kind: Kind::Int { min: 1, max: 32 },
        default: Some("10"),
        help: "environment SG lobes (diffuse=ratio|sg)",
    },
    OptionSpec {
        key: "refine",
        aliases: &[],
        kind: Kind::Int { min: 0, max: 100 },
        default: Some("6"),
        help: "coordinate-descent rounds refining the greedy SG fit (diffuse=ratio|sg; 0: greedy only)",
    },
    OptionSpec {
        key: "counters",
        aliases: &[],
        kind: Kind::Choice(&["off", "traversal", "marking"]),
        default: Some("off"),
        help: "cost model: show per-point work counts instead of radiance: traversal (BVH nodes of the hemisphere traversal, of the lobe traversals, caps marked) or marking (cap rows, map patch lookups, Ŝ corners)",
    },
    crate::passes::shade::env_lights_option("off"),
    crate::passes::shade::tiles::TILES_OPTION,
    crate::passes::shade::tiles::TILE_CAP_OPTION,
    crate::passes::shade::tiles::TILE_LOD_OPTION,
    crate::passes::shade::tiles::REACH_OPTION,
];

impl IsgOptions {
    /// The typed options from values parsed against [`OPTIONS`].
    pub fn from_options(o: &Options) -> Self {
        Self {
            k: o.int("K") as usize,
            side: o.int("patches") as usize,
            epsilon: o.float("eps"),
            node_threshold: o.float("threshold"),
            evaluator: match o.choice("evaluator") {
                "paper" => Evaluator::Paper,
                _ => Evaluator::Table,
            },
            diffuse: match o.choice("diffuse") {
                "sg" => Diffuse::Sg,
                "ratio" => Diffuse::Ratio,
                _ => Diffuse::Map,
            },
            refine: o.int("refine") as usize,
            counters: match o.choice("counters") {
                "traversal" => 1,
                "marking" => 2,
                _ => 0,
            },
            tiles: crate::passes::shade::tiles::TileOptions::from_options(o),
        }
    }

    /// Parse `key=value` pairs against [`OPTIONS`]; unknown keys and bad values are errors naming them.
    pub fn parse(pairs: &[(String, String)]) -> Result<Self, crate::options::OptionError> {
        crate::options::parse("isg", OPTIONS, pairs).map(|o| Self::from_options(&o))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_parse_and_reject() {
        let kv = |s: &str| crate::options::split_spec(&format!("isg:{s}")).unwrap().1;
        let o = IsgOptions::parse(&kv("K=4,patches=20,eps=0.05,threshold=0.5,evaluator=paper,refine=0")).unwrap();
        assert_eq!(o.refine, 0);
        assert_eq!((o.k, o.side, o.evaluator), (4, 20, Evaluator::Paper));
        assert_eq!(IsgOptions::parse(&[]).unwrap(), IsgOptions::default(), "schema defaults = IsgOptions::default()");
        assert_eq!(IsgOptions::parse(&kv("counters=traversal")).unwrap().counters, 1);
        assert_eq!(IsgOptions::parse(&kv("counters=marking")).unwrap().counters, 2);
        assert_eq!(IsgOptions::parse(&kv("counters=off")).unwrap().counters, 0);
        for bad in [
            "K=0",
            "patches=33",
            "eps=1",
            "threshold=-1",
            "evaluator=x",
            "bogus=1",
            "K=x",
            "refine=x",
            "diffuse=x",
            "counters=1",
        ] {
            assert!(IsgOptions::parse(&kv(bad)).is_err(), "{bad}");
        }
    }
}
