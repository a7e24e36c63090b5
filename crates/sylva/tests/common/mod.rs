//! Helpers shared by the integration tests.

pub mod gltf_validator;
pub mod rig_tools;
