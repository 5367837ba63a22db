//! `<sensor>` (with its `<film>`, `<rfilter>` and `<sampler>`) and `<integrator>`: the tables
//! from plugin name to the constructors in `scene/sensor.rs` and `scene/mod.rs`; a nested
//! object is built before the one that owns it, as Mitsuba instantiates them.

use super::properties::Props;
use super::{Builder, Constructor, N, plugin_constructor};
use crate::Result;
use crate::math::filter::Filter;
use crate::plugin::Properties;
use crate::scene::IntegratorSettings;
use crate::scene::sensor::{Camera, Film, Sampler, SamplerType, rfilter};

/// Every `<integrator>` plugin btfpt implements, by Mitsuba plugin name.
const INTEGRATOR_PLUGINS: &[(&str, Constructor<IntegratorSettings>)] = &[
    ("path", IntegratorSettings::path_from_props),
    ("direct", IntegratorSettings::direct_from_props),
];

/// A constructor that also takes the object its plugin owns, built first (a sensor's film, a
/// film's reconstruction filter), as Mitsuba instantiates nested objects before their owner.
type OwnerConstructor<T, Owned> = fn(&dyn Properties, Owned) -> Result<T>;

/// Every `<sensor>` plugin btfpt implements, with its film.
const SENSOR_PLUGINS: &[(&str, OwnerConstructor<Camera, Film>)] = &[
    ("perspective", Camera::perspective_from_props),
    ("thinlens", Camera::thinlens_from_props),
    ("orthographic", Camera::orthographic_from_props),
];

/// Every `<film>` plugin btfpt implements, with its reconstruction filter.
const FILM_PLUGINS: &[(&str, OwnerConstructor<Film, Filter>)] =
    &[("hdrfilm", Film::hdrfilm_from_props)];

/// Every `<rfilter>` plugin btfpt implements.
const RFILTER_PLUGINS: &[(&str, Constructor<Filter>)] = &[
    ("box", rfilter::boxed),
    ("tent", rfilter::tent),
    ("gaussian", rfilter::gaussian),
    ("mitchell", rfilter::mitchell),
    ("catmullrom", rfilter::catmullrom),
    ("lanczos", rfilter::lanczos),
];

/// Every `<sampler>` plugin btfpt accepts (all draw independently, see [`SamplerType`]).
const SAMPLER_PLUGINS: &[(&str, Constructor<Sampler>)] = &[
    ("independent", |p| {
        Sampler::from_props(p, SamplerType::Independent)
    }),
    ("stratified", |p| {
        Sampler::from_props(p, SamplerType::Stratified)
    }),
    ("multijitter", |p| {
        Sampler::from_props(p, SamplerType::Multijitter)
    }),
    ("ldsampler", |p| {
        Sampler::from_props(p, SamplerType::LdSampler)
    }),
    ("orthogonal", |p| {
        Sampler::from_props(p, SamplerType::Orthogonal)
    }),
];

impl<'a, 'x> Builder<'a, 'x> {
    pub(super) fn integrator(&mut self, node: N<'a>) -> Result<IntegratorSettings> {
        let p = Props::parse(self.x, node)?;
        let construct = plugin_constructor(INTEGRATOR_PLUGINS, &p, "integrator type", &[])?;
        let integrator = construct(&p)?;
        p.finish()?;
        Ok(integrator)
    }

    /// The camera and its sampler. No `<film>`: Mitsuba's default hdrfilm; no `<rfilter>`:
    /// its default gaussian; no `<sampler>`: independent, 4 samples per pixel.
    pub(super) fn sensor(&mut self, node: N<'a>) -> Result<(Camera, Sampler)> {
        let x = self.x;
        let p = Props::parse(x, node)?;
        let construct = plugin_constructor(SENSOR_PLUGINS, &p, "sensor type", &[])?;
        let film = match p.single_child("film")? {
            None => Film::default(),
            Some(c) => {
                let f = Props::parse(x, c.node)?;
                let film = plugin_constructor(FILM_PLUGINS, &f, "film type", &[])?;
                let filter = match f.single_child("rfilter")? {
                    None => Filter::default(),
                    Some(c) => {
                        let r = Props::parse(x, c.node)?;
                        let construct =
                            plugin_constructor(RFILTER_PLUGINS, &r, "reconstruction filter", &[])?;
                        let filter = construct(&r)?;
                        r.finish()?;
                        filter
                    }
                };
                let film = film(&f, filter)?;
                f.finish()?;
                film
            }
        };
        let camera = construct(&p, film)?;
        let sampler = match p.single_child("sampler")? {
            None => Sampler::default(),
            Some(c) => {
                let s = Props::parse(x, c.node)?;
                let sampler = plugin_constructor(SAMPLER_PLUGINS, &s, "sampler type", &[])?(&s)?;
                s.finish()?;
                sampler
            }
        };
        p.finish()?;
        Ok((camera, sampler))
    }
}
