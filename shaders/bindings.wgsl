// #requires layout
// The render kernel's scene buffers: bind group 1 (group 0 is the pass contract of
// shaders/pass.wgsl). src/gpu/render.rs binds them in binding order. Only those a scene's
// features need are declared; the packer uploads the same subset.

@group(1) @binding(0) var<uniform> settings: Settings;
@group(1) @binding(1) var<uniform> camera: Camera;
// Count of camera-sample estimates that were NaN or infinite (written as 0 instead).
@group(1) @binding(2) var<storage, read_write> nan_count: atomic<u32>;
// #if GEOMETRY
@group(1) @binding(3) var<storage, read> shapes: array<Shape>;
// BVH leaf object references from 0, then the plane list and CSG children.
@group(1) @binding(4) var<storage, read> indices: array<u32>;
// #endif
// #if BVH
@group(1) @binding(5) var<storage, read> bvh_nodes: array<BvhNode>;
// #endif
// #if CSG
@group(1) @binding(6) var<storage, read> csg_nodes: array<CsgNode>;
// #endif
// #if MATERIALS
@group(1) @binding(7) var<storage, read> materials: array<Material>;
@group(1) @binding(8) var<storage, read> pigments: array<Pigment>;
// #endif
// #if SHADING
@group(1) @binding(9) var<uniform> environment: Environment;
// #endif
// #if TEXTURES
// Texels (rgb triples) of image pigments and the environment, then the environment's
// importance-sampling arrays.
@group(1) @binding(10) var<storage, read> floats: array<f32>;
// #endif
// #if POINT_LIGHTS
@group(1) @binding(11) var<storage, read> point_lights: array<PointLight>;
// #endif
// #if AREA_LIGHTS
@group(1) @binding(12) var<storage, read> area_lights: array<AreaLight>;
// #endif
