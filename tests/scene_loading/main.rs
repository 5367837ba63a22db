//! Scene loading: Mitsuba XML and glTF files written by the tests, parsed into the expected
//! `Scene`, their error messages, and every scene committed to the repository.

mod committed_scenes;
mod gltf;
mod mitsuba_constructs;
mod mitsuba_xml;
mod named_conductors;
mod principled;
mod sensors;
