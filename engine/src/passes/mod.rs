//! `engine::passes`: one file per pass, each with the shader folder of the same name.

pub mod blocker_bvh;
pub mod blocker_spheres;
pub mod cloth;
pub mod gbuffer;
pub mod shade;
pub mod skin;
pub mod thin_shells;
pub mod tonemap;
