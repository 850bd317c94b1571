//! Surface optics in f64 that both renderers share: Fresnel reflectance, the GGX microfacet
//! distribution and the energy tables of its multiple-scattering compensation. The CPU
//! reference evaluates these directly; the GPU packer uploads the tables, so the two
//! renderers compensate with the same numbers.

pub mod compensation;
pub mod energy_tables;
pub mod fresnel;
pub mod ggx;
pub mod metals;
