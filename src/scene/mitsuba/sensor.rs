//! `<sensor>` (with its `<film>`, `<rfilter>` and `<sampler>`) and `<integrator>`: the tables
//! from plugin name to the constructors in `scene/sensor.rs` and `scene/mod.rs`; a nested
//! object is built before the one that owns it, as Mitsuba instantiates them.

use super::properties::Props;
use super::{Builder, Constructor, N, plugin_constructor};
use crate::Result;
use crate::math::filter::Filter;
use crate::plugin::Properties;
use crate::scene::IntegratorSettings;
use crate::scene::channels::{ImageChannels, Nested};
use crate::scene::sensor::{Camera, Film, Sampler, SamplerType, rfilter};

/// Every `<integrator>` plugin btfpt implements, by Mitsuba plugin name.
const INTEGRATOR_PLUGINS: &[(&str, Constructor<IntegratorSettings>)] = &[
    ("path", IntegratorSettings::path_from_props),
    ("direct", IntegratorSettings::direct_from_props),
    ("volpath", IntegratorSettings::volpath_from_props),
    ("volpathmis", IntegratorSettings::volpath_from_props),
    ("ptracer", IntegratorSettings::ptracer_from_props),
];

/// The integrators that wrap one nested integrator and add image channels beside its image.
type WrapperConstructor = fn(&dyn Properties, Option<Nested>) -> Result<ImageChannels>;

/// Every wrapping `<integrator>` plugin btfpt implements, by Mitsuba plugin name.
const WRAPPER_PLUGINS: &[(&str, WrapperConstructor)] = &[
    ("aov", ImageChannels::aov_from_props),
    ("moment", ImageChannels::moment_from_props),
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
    /// The integrator and the extra image channels it writes. `aov` and `moment` wrap at most
    /// one nested `path` or `direct`, which renders the image; an `aov` without one renders
    /// a black image beside its AOVs, as Mitsuba's.
    pub(super) fn integrator(
        &mut self,
        node: N<'a>,
    ) -> Result<(IntegratorSettings, ImageChannels)> {
        let x = self.x;
        let p = Props::parse(x, node)?;
        let wrappers: Vec<&str> = WRAPPER_PLUGINS.iter().map(|(n, _)| *n).collect();
        let Some((_, wrap)) = WRAPPER_PLUGINS.iter().find(|(n, _)| *n == p.ty) else {
            let construct =
                plugin_constructor(INTEGRATOR_PLUGINS, &p, "integrator type", &wrappers)?;
            let integrator = construct(&p)?;
            p.finish()?;
            return Ok((integrator, ImageChannels::default()));
        };
        let nested = p.children_tagged("integrator");
        if let Some(extra) = nested.get(1) {
            return Err(x.err(
                extra.at,
                format!(
                    "integrator \"{}\": btfpt renders one nested integrator (this is the second)",
                    p.ty
                ),
            ));
        }
        let inner = match nested.first() {
            None => None,
            Some(c) => {
                let q = Props::parse(x, c.node)?;
                if wrappers.contains(&q.ty.as_str()) {
                    return Err(q.err(format!(
                        "btfpt does not nest \"{}\" inside \"{}\" (nest path or direct)",
                        q.ty, p.ty
                    )));
                }
                let construct = plugin_constructor(INTEGRATOR_PLUGINS, &q, "integrator type", &[])?;
                let settings = construct(&q)?;
                q.finish()?;
                let name = c.name.clone().unwrap_or_else(|| "_arg_0".to_string());
                Some((name, settings))
            }
        };
        let channels = wrap(
            &p,
            inner
                .as_ref()
                .map(|(name, settings)| Nested { name, settings }),
        )?;
        p.finish()?;
        let settings = match inner {
            Some((_, s)) => s,
            None => IntegratorSettings {
                max_depth: 0,
                ..Default::default()
            },
        };
        Ok((settings, channels))
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
