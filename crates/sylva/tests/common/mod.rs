//! Helpers shared by the integration tests.

pub mod gltf_validator;
