//! The Mitsuba XML document: `<default>` and `$name` substitution (defines win), the id table
//! for references, line lookup and attribute parsing.

use crate::math::Vec3;
use crate::{Error, Result};
use roxmltree::{Document, Node, NodeId};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Elements that denote plugin objects (everything else is a property or a transform op).
pub(crate) const OBJECT_TAGS: &[&str] = &[
    "scene",
    "integrator",
    "sensor",
    "film",
    "rfilter",
    "sampler",
    "shape",
    "bsdf",
    "texture",
    "emitter",
];

/// A parsed Mitsuba XML document: substituted attribute values, the id table and line lookup.
pub(crate) struct XmlDoc<'a> {
    pub file: PathBuf,
    pub dir: PathBuf,
    pub doc: &'a Document<'a>,
    /// Attribute values after `$name` substitution, per element.
    attrs: HashMap<NodeId, Vec<(String, String)>>,
    /// Every object element with an `id` attribute.
    pub ids: HashMap<String, NodeId>,
}

impl<'a> XmlDoc<'a> {
    /// Runs the substitution pass in document order (as Mitsuba does: a `<default>` only applies
    /// to the elements after it; `defines` win over defaults) and collects ids.
    pub fn new(file: &Path, doc: &'a Document<'a>, defines: &[(String, String)]) -> Result<Self> {
        let dir = file.parent().map(Path::to_path_buf).unwrap_or_default();
        let mut x = XmlDoc {
            file: file.to_path_buf(),
            dir,
            doc,
            attrs: HashMap::new(),
            ids: HashMap::new(),
        };
        // (name, value, used)
        let mut params: Vec<(String, String, bool)> = Vec::new();
        for (name, value) in defines {
            if name.is_empty() {
                return Err(Error::Invalid(format!(
                    "{}: empty parameter name in define '={value}'",
                    file.display()
                )));
            }
            params.retain(|p| &p.0 != name);
            params.push((name.clone(), value.clone(), false));
        }
        for node in doc.root_element().descendants() {
            if !node.is_element() {
                continue;
            }
            // Longest names first, so that `$ab` is not replaced by the value of `$a` + "b".
            params.sort_by_key(|p| std::cmp::Reverse(p.0.len()));
            let mut values = Vec::new();
            for a in node.attributes() {
                let mut v = a.value().to_string();
                if !params.is_empty() && v.contains('$') {
                    for p in params.iter_mut() {
                        let pat = format!("${}", p.0);
                        if v.contains(&pat) {
                            v = v.replace(&pat, &p.1);
                            p.2 = true;
                        }
                    }
                    if v.contains('$') {
                        return Err(x.err(
                            node,
                            format!(
                                "undefined parameter(s) in attribute {}=\"{}\"",
                                a.name(),
                                a.value()
                            ),
                        ));
                    }
                }
                values.push((a.name().to_string(), v));
            }
            if node.tag_name().name() == "default" {
                let get = |n: &str| values.iter().find(|(k, _)| k == n).map(|(_, v)| v.clone());
                for (k, _) in &values {
                    if k != "name" && k != "value" {
                        return Err(
                            x.err(node, format!("unexpected attribute \"{k}\" in <default>"))
                        );
                    }
                }
                let (Some(name), Some(value)) = (get("name"), get("value")) else {
                    return Err(x.err(node, "<default> needs both \"name\" and \"value\""));
                };
                if name.is_empty() {
                    return Err(x.err(node, "<default>: name must be non-empty"));
                }
                if !params.iter().any(|p| p.0 == name) {
                    params.push((name, value, true));
                }
            }
            if OBJECT_TAGS.contains(&node.tag_name().name())
                && let Some((_, id)) = values.iter().find(|(k, _)| k == "id")
            {
                if id.starts_with('_') {
                    return Err(x.err(
                        node,
                        format!("invalid id \"{id}\": leading underscores are reserved"),
                    ));
                }
                if let Some(prev) = x.ids.get(id) {
                    let prev_line = x.line(doc.get_node(*prev).unwrap_or(node));
                    return Err(x.err(
                        node,
                        format!(
                            "<{}> has duplicate id \"{id}\" (previous was at line {prev_line})",
                            node.tag_name().name()
                        ),
                    ));
                }
                x.ids.insert(id.clone(), node.id());
            }
            x.attrs.insert(node.id(), values);
        }
        if let Some(p) = params.iter().find(|p| !p.2) {
            return Err(Error::Invalid(format!(
                "{}: unused parameter \"{}\" (given with -D, but the scene has no ${} in it)",
                file.display(),
                p.0,
                p.0
            )));
        }
        Ok(x)
    }

    /// 1-based line of an element.
    pub fn line(&self, node: Node) -> u32 {
        self.doc.text_pos_at(node.range().start).row
    }

    /// A scene error at `node`.
    pub fn err(&self, node: Node, msg: impl Into<String>) -> Error {
        Error::Scene {
            file: self.file.clone(),
            line: self.line(node),
            msg: msg.into(),
        }
    }

    /// The substituted value of attribute `name`.
    pub fn attr(&self, node: Node, name: &str) -> Option<&str> {
        self.attrs
            .get(&node.id())
            .and_then(|v| v.iter().find(|(k, _)| k == name))
            .map(|(_, v)| v.as_str())
    }

    /// A required attribute.
    pub fn req_attr(&self, node: Node, name: &str) -> Result<&str> {
        self.attr(node, name).ok_or_else(|| {
            self.err(
                node,
                format!(
                    "missing attribute \"{name}\" in element <{}>",
                    node.tag_name().name()
                ),
            )
        })
    }

    /// Errors if the element has an attribute outside `allowed`.
    pub fn check_attrs(&self, node: Node, allowed: &[&str]) -> Result<()> {
        if let Some(v) = self.attrs.get(&node.id()) {
            for (k, _) in v {
                if !allowed.contains(&k.as_str()) {
                    return Err(self.err(
                        node,
                        format!(
                            "unexpected attribute \"{k}\" in element <{}>",
                            node.tag_name().name()
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Resolves a path attribute relative to the scene file's folder.
    pub fn resolve(&self, p: &str) -> PathBuf {
        let p = Path::new(p);
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            self.dir.join(p)
        }
    }

    /// Parses a finite float attribute value.
    pub fn parse_f32(&self, node: Node, s: &str) -> Result<f32> {
        let v: f64 = s.trim().parse().map_err(|_| {
            self.err(
                node,
                format!("could not parse floating point value \"{s}\""),
            )
        })?;
        if !v.is_finite() || !(v as f32).is_finite() {
            return Err(self.err(
                node,
                format!("non-finite value \"{s}\" (NaN/Inf are not allowed)"),
            ));
        }
        Ok(v as f32)
    }

    /// Splits a list of numbers separated by commas and/or whitespace, as Mitsuba's tokenizer does.
    pub fn parse_list(&self, node: Node, s: &str) -> Result<Vec<f32>> {
        s.split(|c: char| c == ',' || c.is_whitespace())
            .filter(|t| !t.is_empty())
            .map(|t| self.parse_f32(node, t))
            .collect()
    }

    /// `x`/`y`/`z` attributes (or a `value` holding 1 or 3 numbers), missing components = `default`.
    pub fn parse_xyz(&self, node: Node, default: f32) -> Result<Vec3> {
        if let Some(v) = self.attr(node, "value") {
            if self.attr(node, "x").is_some()
                || self.attr(node, "y").is_some()
                || self.attr(node, "z").is_some()
            {
                return Err(self.err(node, "can't mix \"value\" and \"x\"/\"y\"/\"z\" attributes"));
            }
            let l = self.parse_list(node, v)?;
            return match l.len() {
                1 => Ok(Vec3::splat(l[0])),
                3 => Ok(Vec3::new(l[0], l[1], l[2])),
                _ => Err(self.err(
                    node,
                    "\"value\" attribute must have exactly 1 or 3 elements",
                )),
            };
        }
        let mut out = Vec3::splat(default);
        for (i, k) in ["x", "y", "z"].iter().enumerate() {
            if let Some(s) = self.attr(node, k) {
                out[i] = self.parse_f32(node, s)?;
            }
        }
        Ok(out)
    }

    /// A named 3-vector attribute such as `origin="0, 0, 1"`.
    pub fn parse_vec3_attr(&self, node: Node, name: &str) -> Result<Vec3> {
        let s = self.req_attr(node, name)?;
        let l = self.parse_list(node, s)?;
        if l.len() != 3 {
            return Err(self.err(
                node,
                format!("\"{name}\" attribute must have exactly 3 elements"),
            ));
        }
        Ok(Vec3::new(l[0], l[1], l[2]))
    }

    /// The element an object-position node denotes: itself, or the target of a `<ref>`.
    pub fn deref(&self, node: Node<'a, 'a>) -> Result<Node<'a, 'a>> {
        if node.tag_name().name() != "ref" {
            return Ok(node);
        }
        self.check_attrs(node, &["id", "name"])?;
        let id = self.req_attr(node, "id")?;
        let target = self
            .ids
            .get(id)
            .and_then(|nid| self.doc.get_node(*nid))
            .ok_or_else(|| self.err(node, format!("reference to unknown object \"{id}\"")))?;
        Ok(target)
    }
}
