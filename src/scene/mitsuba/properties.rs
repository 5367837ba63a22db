//! A typed property bag per plugin element that remembers line numbers and which properties were
//! queried (Mitsuba errors on properties a plugin never looked at, and so do we: `finish`).

use super::document::{OBJECT_TAGS, XmlDoc};
use crate::Error;
use crate::Result;
use crate::math::Vec3;
use crate::plugin::{Properties, Value};
use roxmltree::Node;
use std::cell::Cell;
use std::path::PathBuf;

struct Prop<'a> {
    name: String,
    value: Value,
    node: Node<'a, 'a>,
    used: Cell<bool>,
}

/// A nested object (or the target of a `<ref>`) inside a plugin element.
pub(crate) struct Child<'a> {
    /// The `name` attribute, if any.
    pub name: Option<String>,
    /// The object element itself (a `<ref>` already resolved).
    pub node: Node<'a, 'a>,
    /// The element as written (the `<ref>` for references), for messages.
    pub at: Node<'a, 'a>,
    used: Cell<bool>,
}

impl Child<'_> {
    /// The object's tag: bsdf, texture, emitter, ...
    pub fn tag(&self) -> &str {
        self.node.tag_name().name()
    }
}

/// The properties and nested objects of one plugin element, with query tracking.
pub(crate) struct Props<'a, 'x> {
    pub x: &'x XmlDoc<'a>,
    pub node: Node<'a, 'a>,
    /// Element tag (bsdf, shape, ...) and `type` attribute.
    pub tag: String,
    pub ty: String,
    props: Vec<Prop<'a>>,
    children: Vec<Child<'a>>,
}

impl<'a, 'x> Props<'a, 'x> {
    /// Parses the children of a plugin element.
    pub fn parse(x: &'x XmlDoc<'a>, node: Node<'a, 'a>) -> Result<Self> {
        let tag = node.tag_name().name().to_string();
        if node.parent_element().is_none() {
            // The root object of an included object file carries the file's version.
            x.check_attrs(node, &["type", "id", "name", "version"])?;
        } else {
            x.check_attrs(node, &["type", "id", "name"])?;
        }
        let ty = x.req_attr(node, "type")?.to_string();
        let mut props: Vec<Prop<'a>> = Vec::new();
        let mut children = Vec::new();
        if let Some(t) = node
            .children()
            .find(|c| c.is_text() && !c.text().unwrap_or("").trim().is_empty())
        {
            return Err(x.err(t, format!("unexpected text content in <{tag}>")));
        }
        for ch in x.children(node) {
            let ctag = ch.tag_name().name();
            if OBJECT_TAGS.contains(&ctag) || ctag == "ref" {
                let target = x.deref(ch)?;
                if target == node {
                    return Err(x.err(ch, "an object cannot reference itself"));
                }
                if ctag != "ref" {
                    x.check_attrs(ch, &["type", "id", "name"])?;
                    x.req_attr(ch, "type")?;
                }
                children.push(Child {
                    name: x.attr(ch, "name").map(str::to_string),
                    node: target,
                    at: ch,
                    used: Cell::new(false),
                });
                continue;
            }
            let value = match ctag {
                "float" => {
                    x.check_attrs(ch, &["name", "value"])?;
                    Value::Float(x.parse_f32(ch, x.req_attr(ch, "value")?)?)
                }
                "integer" => {
                    x.check_attrs(ch, &["name", "value"])?;
                    let s = x.req_attr(ch, "value")?;
                    Value::Integer(
                        s.trim().parse().map_err(|_| {
                            x.err(ch, format!("could not parse integer value \"{s}\""))
                        })?,
                    )
                }
                "boolean" => {
                    x.check_attrs(ch, &["name", "value"])?;
                    let s = x.req_attr(ch, "value")?;
                    match s.trim().to_ascii_lowercase().as_str() {
                        "true" => Value::Boolean(true),
                        "false" => Value::Boolean(false),
                        _ => {
                            return Err(x.err(
                                ch,
                                format!("could not parse boolean value \"{s}\" -- must be \"true\" or \"false\""),
                            ));
                        }
                    }
                }
                "string" => {
                    x.check_attrs(ch, &["name", "value"])?;
                    Value::String(x.req_attr(ch, "value")?.to_string())
                }
                "rgb" => {
                    x.check_attrs(ch, &["name", "value"])?;
                    let l = x.parse_list(ch, x.req_attr(ch, "value")?)?;
                    match l.len() {
                        1 => Value::Rgb(Vec3::splat(l[0])),
                        3 => Value::Rgb(Vec3::new(l[0], l[1], l[2])),
                        _ => return Err(x.err(ch, "'rgb' tag requires one or three values")),
                    }
                }
                "spectrum" => parse_spectrum(x, ch)?,
                "point" | "vector" => {
                    x.check_attrs(ch, &["name", "value", "x", "y", "z"])?;
                    let v = x.parse_xyz(ch, 0.0)?;
                    if ctag == "point" {
                        Value::Point(v)
                    } else {
                        Value::Vector(v)
                    }
                }
                "transform" => {
                    x.check_attrs(ch, &["name"])?;
                    Value::Transform(super::transform::parse_transform(x, ch)?)
                }
                "translate" | "rotate" | "scale" | "matrix" | "lookat" => {
                    return Err(x.err(ch, format!("<{ctag}> can only occur inside a <transform>")));
                }
                other => return Err(x.err(ch, format!("unexpected element <{other}> in <{tag}>"))),
            };
            let name = x.req_attr(ch, "name")?.to_string();
            if let Some(prev) = props.iter().find(|p| p.name == name) {
                return Err(x.err(
                    ch,
                    format!(
                        "property \"{name}\" was specified multiple times (also at line {})",
                        x.line(prev.node)
                    ),
                ));
            }
            props.push(Prop {
                name,
                value,
                node: ch,
                used: Cell::new(false),
            });
        }
        Ok(Props {
            x,
            node,
            tag,
            ty,
            props,
            children,
        })
    }

    /// A scene error at this plugin element.
    pub fn err(&self, msg: impl Into<String>) -> Error {
        self.x.err(
            self.node,
            format!("{} \"{}\": {}", self.tag, self.ty, msg.into()),
        )
    }

    fn err_at_node(&self, node: Node, msg: impl Into<String>) -> Error {
        self.x.err(
            node,
            format!("{} \"{}\": {}", self.tag, self.ty, msg.into()),
        )
    }

    /// The nested object named `name` (as a `name` attribute), marking it used.
    pub fn child_named(&self, name: &str) -> Option<&Child<'a>> {
        let c = self
            .children
            .iter()
            .find(|c| c.name.as_deref() == Some(name))?;
        c.used.set(true);
        Some(c)
    }

    /// All nested objects with tag `tag`, marking them used.
    pub fn children_tagged(&self, tag: &str) -> Vec<&Child<'a>> {
        let v: Vec<&Child<'a>> = self.children.iter().filter(|c| c.tag() == tag).collect();
        for c in &v {
            c.used.set(true);
        }
        v
    }

    /// At most one nested object with tag `tag`.
    pub fn single_child(&self, tag: &str) -> Result<Option<&Child<'a>>> {
        let v = self.children_tagged(tag);
        if v.len() > 1 {
            return Err(self.err_at_node(v[1].at, format!("more than one nested <{tag}>")));
        }
        Ok(v.first().copied())
    }

    /// Errors on any property or nested object the plugin never looked at (Mitsuba semantics).
    pub fn finish(&self) -> Result<()> {
        if let Some(p) = self.props.iter().find(|p| !p.used.get()) {
            return Err(self.err_at_node(
                p.node,
                format!(
                    "unreferenced property \"{}\" ({}) in {} plugin of type \"{}\"",
                    p.name,
                    p.value.kind(),
                    self.tag,
                    self.ty
                ),
            ));
        }
        if let Some(c) = self.children.iter().find(|c| !c.used.get()) {
            return Err(self.err_at_node(
                c.at,
                format!(
                    "unreferenced nested <{}> in {} plugin of type \"{}\"",
                    c.tag(),
                    self.tag,
                    self.ty
                ),
            ));
        }
        Ok(())
    }
}

/// The XML element as a plugin's [`Properties`]: errors name the file, the line of the
/// element (or of the property) and the plugin.
impl Properties for Props<'_, '_> {
    fn plugin_type(&self) -> &str {
        &self.ty
    }

    fn err(&self, msg: &str) -> Error {
        Props::err(self, msg)
    }

    fn err_at(&self, name: &str, msg: &str) -> Error {
        let node = self
            .props
            .iter()
            .find(|p| p.name == name)
            .map(|p| p.node)
            .or_else(|| {
                self.children
                    .iter()
                    .find(|c| c.name.as_deref() == Some(name))
                    .map(|c| c.at)
            })
            .unwrap_or(self.node);
        self.err_at_node(node, msg)
    }

    fn has(&self, name: &str) -> bool {
        self.props.iter().any(|p| p.name == name)
            || self
                .children
                .iter()
                .any(|c| c.name.as_deref() == Some(name))
    }

    fn value(&self, name: &str) -> Option<&Value> {
        let p = self.props.iter().find(|p| p.name == name)?;
        p.used.set(true);
        Some(&p.value)
    }

    fn nested_tag(&self, name: &str) -> Option<&str> {
        let c = self
            .children
            .iter()
            .find(|c| c.name.as_deref() == Some(name))?;
        c.used.set(true);
        Some(c.tag())
    }

    fn resolve(&self, filename: &str) -> PathBuf {
        self.x.resolve(filename)
    }

    fn mitsuba_0_6(&self) -> bool {
        self.x.is_legacy(self.node)
    }
}

/// A `<spectrum>` property: `value` (one number, or wavelength:value pairs separated by commas
/// or spaces) or `filename` (a `.spd` file: a wavelength and a value per line, `#` comments),
/// checked as Mitsuba 3.9.1's `Properties::Spectrum` checks them.
fn parse_spectrum(x: &XmlDoc, ch: Node) -> Result<Value> {
    if let Some(t) = x.attr(ch, "type") {
        return Err(x.err(
            ch,
            format!(
                "<spectrum type=\"{t}\"> is a spectral plugin: not supported (btfpt renders in RGB; \
                 give <rgb> or a <spectrum value=\"...\"> list)"
            ),
        ));
    }
    x.check_attrs(ch, &["name", "value", "filename"])?;
    let (value, file) = (x.attr(ch, "value"), x.attr(ch, "filename"));
    let pairs: Vec<(f64, f64)> = match (value, file) {
        (Some(s), None) => {
            let tokens: Vec<&str> = s
                .split(|c: char| c == ',' || c.is_whitespace())
                .filter(|t| !t.is_empty())
                .collect();
            if tokens.len() == 1 && !tokens[0].contains(':') {
                return Ok(Value::Spectrum(x.parse_f32(ch, tokens[0])?));
            }
            let mut pairs = Vec::with_capacity(tokens.len());
            for t in tokens {
                let pair = t.split_once(':').and_then(|(w, v)| {
                    let w = w.trim().parse::<f64>().ok()?;
                    let v = v.trim().parse::<f64>().ok()?;
                    Some((w, v))
                });
                match pair {
                    Some(p) => pairs.push(p),
                    None => {
                        return Err(x.err(
                            ch,
                            format!(
                                "invalid spectrum value \"{t}\" (expected wavelength:value pairs)"
                            ),
                        ));
                    }
                }
            }
            pairs
        }
        (None, Some(f)) => {
            let path = x.resolve(f);
            let text = std::fs::read_to_string(&path).map_err(|e| {
                x.err(
                    ch,
                    format!("cannot read spectrum file \"{}\": {e}", path.display()),
                )
            })?;
            read_spd(&text)
                .map_err(|m| x.err(ch, format!("spectrum file \"{}\": {m}", path.display())))?
        }
        _ => {
            return Err(x.err(
                ch,
                "<spectrum> element requires either \"value\" or \"filename\" attribute (but not both)",
            ));
        }
    };
    if pairs.len() < 2 {
        return Err(x.err(ch, "a spectrum must have at least two entries"));
    }
    if pairs.iter().any(|(w, v)| !w.is_finite() || !v.is_finite()) {
        return Err(x.err(ch, "non-finite wavelength or value in spectrum"));
    }
    if pairs.windows(2).any(|p| p[1].0 <= p[0].0) {
        return Err(x.err(ch, "wavelengths must be specified in increasing order"));
    }
    let (w, v) = pairs.into_iter().unzip();
    Ok(Value::SpectrumList(w, v))
}

/// The (wavelength, value) lines of a `.spd` file as Mitsuba reads them: lines starting with
/// `#` and empty lines skipped, otherwise two numbers first on the line.
fn read_spd(text: &str) -> std::result::Result<Vec<(f64, f64)>, String> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.starts_with('#') || line.trim_end_matches('\r').is_empty() {
            continue;
        }
        let mut it = line.split_whitespace().map(str::parse::<f64>);
        match (it.next(), it.next()) {
            (Some(Ok(w)), Some(Ok(v))) => out.push((w, v)),
            _ => {
                return Err(format!(
                    "line {}: expected a wavelength and a value, found \"{}\"",
                    i + 1,
                    line.trim()
                ));
            }
        }
    }
    Ok(out)
}
