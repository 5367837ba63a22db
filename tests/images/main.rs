//! Images against the committed Mitsuba 3 references (`reference-images/`): the Cornell and
//! feature scenes, raw BTFs and fitted PLM-C models, scored with `btfpt::metrics`.

mod mitsuba_aov;
mod mitsuba_scenes;
mod plmc;
mod raw_btf;
mod reference;
