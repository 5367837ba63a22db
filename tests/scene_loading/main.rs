//! Scene loading: Mitsuba XML and glTF files written by the tests, parsed into the expected
//! `Scene`, their error messages, and every scene committed to the repository.

mod committed_scenes;
#[path = "../common/mod.rs"]
mod common;
mod fixtures;
mod gltf;
mod mesh_attributes;
mod mitsuba_constructs;
mod mitsuba_xml;
mod named_conductors;
mod principled;
mod sensors;
