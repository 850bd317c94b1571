// The render kernel's buffers (src/gpu/render.rs binds them in this order). Only those a
// scene's features need are declared: the packer uploads the same subset.

@group(0) @binding(0) var<uniform> settings: Settings;
@group(0) @binding(1) var<uniform> camera: Camera;
// Per pixel: rgb = sum of this pass's sample estimates, a = count of NaN/∞ estimates
// (replaced by 0 in the sum).
@group(0) @binding(2) var<storage, read_write> output: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> shapes: array<Shape>;
// BVH leaf object references from 0, then the plane list, CSG children and area lights.
@group(0) @binding(4) var<storage, read> indices: array<u32>;
// #if BVH
@group(0) @binding(5) var<storage, read> bvh_nodes: array<BvhNode>;
// #endif
// #if CSG
@group(0) @binding(6) var<storage, read> csg_nodes: array<CsgNode>;
// #endif
// #if SHADING
@group(0) @binding(7) var<storage, read> materials: array<Material>;
@group(0) @binding(8) var<storage, read> pigments: array<Pigment>;
@group(0) @binding(9) var<uniform> environment: Environment;
// #endif
// #if TEXTURES
// Texels (rgb triples) of image pigments and the environment, then the environment's
// importance-sampling arrays.
@group(0) @binding(10) var<storage, read> floats: array<f32>;
// #endif
// #if POINT_LIGHTS
@group(0) @binding(11) var<storage, read> point_lights: array<PointLight>;
// #endif
