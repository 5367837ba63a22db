//! The Mitsuba XML document: the root file and every file it `<include>`s, `<default>` and
//! `$name` substitution (defines win), `<path>` search folders, ids and `<alias>`es for
//! references, Mitsuba 0.6 (version < 2) property-name upgrades, line lookup and attribute
//! parsing. Semantics of Mitsuba 3.9's `src/core/parser.cpp`.

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

/// Mitsuba's `max_include_depth`: deeper `<include>` nesting is an error.
const MAX_INCLUDE_DEPTH: usize = 15;

/// An element of one of the loaded documents: (document index, node id).
pub(crate) type Key = (usize, NodeId);

/// What [`XmlDoc::load`] found: the whole document, or the next included file to read first.
pub(crate) enum Loaded<'a> {
    /// Every `<include>` was available.
    Done(Box<XmlDoc<'a>>),
    /// The next `<include>` (in document order) names this file, not yet read; it exists.
    Need(PathBuf),
}

/// A parsed Mitsuba XML document: substituted attribute values, the id table and line lookup.
pub(crate) struct XmlDoc<'a> {
    /// The root scene file.
    pub file: PathBuf,
    /// Its folder (relative filenames that match no `<path>` resolve against it).
    pub dir: PathBuf,
    /// The root document then each included one, in the order the includes occur.
    docs: Vec<&'a Document<'a>>,
    files: Vec<PathBuf>,
    /// Major version per document (`version="0.6.0"` → 0): below 2 is upgraded.
    majors: Vec<u32>,
    /// Attribute values after `$name` substitution (and 0.6 renames), per element.
    attrs: HashMap<Key, Vec<(String, String)>>,
    /// Every object element with an `id` attribute, and every `<alias as>`.
    pub ids: HashMap<String, Key>,
    /// `<include>` element → index of the included document.
    includes: HashMap<Key, usize>,
    /// Root-level `<path>` folders, most recent first (Mitsuba prepends them to its resolver).
    search: Vec<PathBuf>,
    /// Every filename resolved for a plugin, in order (meshes, textures, BTFs …): with the
    /// included files, what the scene reads besides its root file.
    resolved: std::cell::RefCell<Vec<PathBuf>>,
}

/// The substitution pass state.
struct Walk {
    /// (name, value, used)
    params: Vec<(String, String, bool)>,
    /// Files being included, outermost first (cycle detection).
    stack: Vec<PathBuf>,
}

/// Mitsuba's `camel_to_underscore_case` (parser.cpp): `intIOR` → `int_ior`, `toWorld` →
/// `to_world`; names already in snake case are unchanged.
pub(crate) fn camel_to_snake(s: &str) -> String {
    let b: Vec<char> = s.chars().collect();
    let mut out = String::with_capacity(s.len() + 4);
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        if i > 0 && b[i - 1].is_ascii_lowercase() && c.is_ascii_uppercase() {
            out.push('_');
            out.push(c.to_ascii_lowercase());
            while i + 1 < b.len() && b[i + 1].is_ascii_uppercase() {
                i += 1;
                out.push(b[i].to_ascii_lowercase());
            }
        } else {
            out.push(c);
        }
        i += 1;
    }
    out
}

/// The major number of a `version` attribute ("0.6.0" → 0), None if it is not a version.
fn major_version(v: &str) -> Option<u32> {
    let mut parts = v.trim().split('.');
    let major = parts.next()?.trim().parse::<u32>().ok()?;
    if parts.any(|p| p.trim().parse::<u32>().is_err()) {
        return None;
    }
    Some(major)
}

impl<'a> XmlDoc<'a> {
    /// Runs the substitution pass in document order over `docs[0]` (the file `files[0]`) and
    /// the documents its `<include>`s name, `docs[k]` being the k-th include met in document
    /// order (as Mitsuba does: a `<default>` only applies to the elements after it, also in
    /// included files; `defines` win over defaults), and collects ids. Returns
    /// [`Loaded::Need`] when an include names a file not in `docs` yet.
    pub fn load(
        files: &[PathBuf],
        docs: Vec<&'a Document<'a>>,
        defines: &[(String, String)],
    ) -> Result<Loaded<'a>> {
        let file = files[0].clone();
        let dir = file.parent().map(Path::to_path_buf).unwrap_or_default();
        let mut x = XmlDoc {
            file: file.clone(),
            dir,
            docs,
            files: files.to_vec(),
            majors: Vec::new(),
            attrs: HashMap::new(),
            ids: HashMap::new(),
            includes: HashMap::new(),
            search: Vec::new(),
            resolved: std::cell::RefCell::new(Vec::new()),
        };
        let mut w = Walk {
            params: Vec::new(),
            stack: vec![file.clone()],
        };
        for (name, value) in defines {
            if name.is_empty() {
                return Err(Error::Invalid(format!(
                    "{}: empty parameter name in define '={value}'",
                    file.display()
                )));
            }
            w.params.retain(|p| &p.0 != name);
            w.params.push((name.clone(), value.clone(), false));
        }
        x.majors.push(x.doc_major(0)?);
        let root = x.docs[0].root_element();
        if let Some(need) = x.walk(&mut w, root, None)? {
            return Ok(Loaded::Need(need));
        }
        if let Some(p) = w.params.iter().find(|p| !p.2) {
            return Err(Error::Invalid(format!(
                "{}: unused parameter \"{}\" (given with -D, but the scene has no ${} in it)",
                file.display(),
                p.0,
                p.0
            )));
        }
        Ok(Loaded::Done(Box::new(x)))
    }

    /// The version of document `d`'s root (required, as in Mitsuba).
    fn doc_major(&self, d: usize) -> Result<u32> {
        let root = self.docs[d].root_element();
        let v = root.attribute("version").ok_or_else(|| {
            self.err(
                root,
                format!(
                    "missing version attribute in root element <{}>",
                    root.tag_name().name()
                ),
            )
        })?;
        major_version(v).ok_or_else(|| self.err(root, format!("invalid version number \"{v}\"")))
    }

    /// Index of the document holding `node`.
    fn doc_of(&self, node: Node) -> usize {
        let d = node.document();
        self.docs
            .iter()
            .position(|x| std::ptr::eq(*x, d))
            .unwrap_or(0)
    }

    /// The key of an element (unique across the included documents).
    pub fn key(&self, node: Node) -> Key {
        (self.doc_of(node), node.id())
    }

    /// The file an element comes from.
    pub fn file_of(&self, node: Node) -> &Path {
        &self.files[self.doc_of(node)]
    }

    /// True if the element comes from a Mitsuba 0.x/1.x file (upgraded on load).
    pub fn is_legacy(&self, node: Node) -> bool {
        self.majors.get(self.doc_of(node)).is_some_and(|m| *m < 2)
    }

    /// Substitutes the attributes of `node` and its descendants in document order, following
    /// includes. `parent` is the enclosing element (None for a document's root).
    fn walk(
        &mut self,
        w: &mut Walk,
        node: Node<'a, 'a>,
        parent: Option<Node<'a, 'a>>,
    ) -> Result<Option<PathBuf>> {
        let d = self.doc_of(node);
        let tag = node.tag_name().name();
        let legacy = self.majors[d] < 2;
        // Longest names first, so that `$ab` is not replaced by the value of `$a` + "b".
        w.params.sort_by_key(|p| std::cmp::Reverse(p.0.len()));
        let mut values = self.substitute(w, node)?;
        // Mitsuba 0.6 files: property names (of every property and nested object of an
        // object) go from camelCase to snake_case; diffuse's diffuse_reflectance → reflectance.
        if legacy
            && tag != "default"
            && let Some(par) = parent
            && OBJECT_TAGS.contains(&par.tag_name().name())
            && let Some(n) = values.iter_mut().find(|(k, _)| k == "name")
        {
            n.1 = camel_to_snake(&n.1);
            let par_ty = self.attr(par, "type").unwrap_or("");
            if par.tag_name().name() == "bsdf"
                && par_ty == "diffuse"
                && n.1 == "diffuse_reflectance"
            {
                n.1 = "reflectance".into();
            }
        }
        let get = |n: &str| values.iter().find(|(k, _)| k == n).map(|(_, v)| v.clone());
        match tag {
            "default" => {
                for (k, _) in &values {
                    if k != "name" && k != "value" {
                        return Err(
                            self.err(node, format!("unexpected attribute \"{k}\" in <default>"))
                        );
                    }
                }
                let (Some(name), Some(value)) = (get("name"), get("value")) else {
                    return Err(self.err(node, "<default> needs both \"name\" and \"value\""));
                };
                if name.is_empty() {
                    return Err(self.err(node, "<default>: name must be non-empty"));
                }
                if !w.params.iter().any(|p| p.0 == name) {
                    w.params.push((name, value, true));
                }
            }
            "alias" => {
                for (k, _) in &values {
                    if k != "id" && k != "as" {
                        return Err(
                            self.err(node, format!("unexpected attribute \"{k}\" in <alias>"))
                        );
                    }
                }
                let (Some(src), Some(dst)) = (get("id"), get("as")) else {
                    return Err(self.err(node, "<alias> needs both \"id\" and \"as\""));
                };
                if self.ids.contains_key(&dst) {
                    return Err(self.err(
                        node,
                        format!("alias destination ID \"{dst}\" already exists"),
                    ));
                }
                let Some(&target) = self.ids.get(&src) else {
                    return Err(self.err(
                        node,
                        format!("alias source ID \"{src}\" not found (it must be defined before the <alias>)"),
                    ));
                };
                self.ids.insert(dst, target);
            }
            "path" => {
                for (k, _) in &values {
                    if k != "value" {
                        return Err(
                            self.err(node, format!("unexpected attribute \"{k}\" in <path>"))
                        );
                    }
                }
                let Some(v) = get("value") else {
                    return Err(self.err(node, "<path> needs a \"value\" attribute"));
                };
                if parent.is_some_and(|p| p.parent_element().is_some()) {
                    return Err(self.err(node, "<path> can only be a child of the root <scene>"));
                }
                let here = self.files[d]
                    .parent()
                    .map(Path::to_path_buf)
                    .unwrap_or_default();
                let p = Path::new(&v);
                // Relative to this file's folder, else through the file resolver (Mitsuba).
                let folder = if p.is_absolute() {
                    p.to_path_buf()
                } else {
                    std::iter::once(here.join(p))
                        .chain(self.resolver(w).into_iter().map(|b| b.join(p)))
                        .find(|c| c.is_dir())
                        .unwrap_or_else(|| here.join(p))
                };
                if !folder.is_dir() {
                    return Err(self.err(
                        node,
                        format!("<path>: folder \"{}\" not found", folder.display()),
                    ));
                }
                // Only the root file's <path>s outlive the parse (Mitsuba restores its resolver
                // after an include), and plugins resolve their files after the whole parse.
                if d == 0 {
                    self.search.insert(0, folder);
                }
            }
            _ => {}
        }
        if OBJECT_TAGS.contains(&tag)
            && let Some(id) = get("id")
        {
            if id.starts_with('_') {
                return Err(self.err(
                    node,
                    format!("invalid id \"{id}\": leading underscores are reserved"),
                ));
            }
            if let Some(prev) = self.ids.get(&id) {
                let prev_node = self.node(*prev).unwrap_or(node);
                let at = format!(
                    "{} line {}",
                    self.file_of(prev_node).display(),
                    self.line(prev_node)
                );
                return Err(self.err(
                    node,
                    format!("<{tag}> has duplicate id \"{id}\" (previous was at {at})"),
                ));
            }
            let k = self.key(node);
            self.ids.insert(id, k);
        }
        let key = self.key(node);
        self.attrs.insert(key, values);
        if tag == "include" {
            return self.include(w, node);
        }
        if tag == "transform" {
            // Transform operations have no properties to rename and no includes.
            for ch in node.descendants().skip(1).filter(|c| c.is_element()) {
                let vals = self.substitute(w, ch)?;
                self.attrs.insert(self.key(ch), vals);
            }
            return Ok(None);
        }
        for ch in node.children().filter(|c| c.is_element()) {
            if let Some(need) = self.walk(w, ch, Some(node))? {
                return Ok(Some(need));
            }
        }
        Ok(None)
    }

    /// `$name` substitution of one element's attributes (every element, transform operations too).
    fn substitute(&self, w: &mut Walk, node: Node) -> Result<Vec<(String, String)>> {
        let mut values = Vec::new();
        for a in node.attributes() {
            let mut v = a.value().to_string();
            if v.contains('$') {
                for p in w.params.iter_mut() {
                    let pat = format!("${}", p.0);
                    if v.contains(&pat) {
                        v = v.replace(&pat, &p.1);
                        p.2 = true;
                    }
                }
                if v.contains('$') {
                    return Err(self.err(
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
        Ok(values)
    }

    /// An `<include filename>`: the file is found relative to the including file's folder
    /// (then the root's `<path>`s); the next unread document is the one it names.
    fn include(&mut self, w: &mut Walk, node: Node<'a, 'a>) -> Result<Option<PathBuf>> {
        self.check_attrs(node, &["filename", "name"])?;
        let name = self.req_attr(node, "filename")?.to_string();
        let d = self.doc_of(node);
        let here = self.files[d]
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_default();
        let p = Path::new(&name);
        let path = if p.is_absolute() {
            p.to_path_buf()
        } else {
            std::iter::once(here.join(p))
                .chain(self.resolver(w).into_iter().map(|b| b.join(p)))
                .find(|c| c.is_file())
                .unwrap_or_else(|| here.join(p))
        };
        if !path.is_file() {
            return Err(self.err(
                node,
                format!("included file \"{}\" not found", path.display()),
            ));
        }
        let canon = path.canonicalize().unwrap_or_else(|_| path.clone());
        if let Some(i) = w
            .stack
            .iter()
            .position(|f| f.canonicalize().unwrap_or_else(|_| f.clone()) == canon)
        {
            let chain: Vec<String> = w.stack[i..]
                .iter()
                .chain(std::iter::once(&path))
                .map(|f| f.display().to_string())
                .collect();
            return Err(self.err(
                node,
                format!("<include> cycle: {}", chain.join(" includes ")),
            ));
        }
        if w.stack.len() >= MAX_INCLUDE_DEPTH {
            return Err(self.err(
                node,
                format!("exceeded the maximum include depth of {MAX_INCLUDE_DEPTH}"),
            ));
        }
        let next = self.includes.len() + 1;
        if next >= self.docs.len() {
            return Ok(Some(path));
        }
        self.includes.insert(self.key(node), next);
        self.majors.push(self.doc_major(next)?);
        w.stack.push(path);
        let root = self.docs[next].root_element();
        let r = self.walk(w, root, None);
        w.stack.pop();
        r
    }

    /// Mitsuba's file resolver during the parse, after the current file's own folder: the
    /// folders of the files including it (innermost first), the root's `<path>`s, the root's
    /// folder and the working directory.
    fn resolver(&self, w: &Walk) -> Vec<PathBuf> {
        let mut v: Vec<PathBuf> = w
            .stack
            .iter()
            .rev()
            .skip(1)
            .filter_map(|f| f.parent().map(Path::to_path_buf))
            .collect();
        v.extend(self.search.iter().cloned());
        v.push(self.dir.clone());
        v.push(PathBuf::from("."));
        v
    }

    /// The element children of `node` as Mitsuba sees them: an `<include>` of a `<scene>` file
    /// stands for that scene's children, an `<include>` of an object file for its root;
    /// `<alias>`, `<path>` and `<default>` (handled by the substitution pass) are left out.
    pub fn children(&self, node: Node<'a, 'a>) -> Vec<Node<'a, 'a>> {
        let mut out = Vec::new();
        for ch in node.children().filter(|c| c.is_element()) {
            match ch.tag_name().name() {
                "alias" | "path" | "default" => {}
                "include" => {
                    if let Some(&d) = self.includes.get(&self.key(ch)) {
                        let root = self.docs[d].root_element();
                        if root.tag_name().name() == "scene" {
                            out.extend(self.children(root));
                        } else {
                            out.push(root);
                        }
                    }
                }
                _ => out.push(ch),
            }
        }
        out
    }

    /// The element a key denotes.
    pub fn node(&self, k: Key) -> Option<Node<'a, 'a>> {
        self.docs.get(k.0)?.get_node(k.1)
    }

    /// 1-based line of an element.
    pub fn line(&self, node: Node) -> u32 {
        node.document().text_pos_at(node.range().start).row
    }

    /// A scene error at `node` (naming the file it comes from).
    pub fn err(&self, node: Node, msg: impl Into<String>) -> Error {
        Error::Scene {
            file: self.file_of(node).to_path_buf(),
            line: self.line(node),
            msg: msg.into(),
        }
    }

    /// The substituted value of attribute `name`.
    pub fn attr(&self, node: Node, name: &str) -> Option<&str> {
        self.attrs
            .get(&self.key(node))
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
        if let Some(v) = self.attrs.get(&self.key(node)) {
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

    /// Resolves a plugin's filename as Mitsuba's file resolver does after the parse: the
    /// root file's `<path>` folders (latest first), then the root file's folder, then the
    /// working directory; a file found nowhere resolves against the root folder (for the
    /// error message).
    pub fn resolve(&self, p: &str) -> PathBuf {
        let p = Path::new(p);
        let found = if p.is_absolute() {
            p.to_path_buf()
        } else {
            self.search
                .iter()
                .chain(std::iter::once(&self.dir))
                .map(|d| d.join(p))
                .chain(std::iter::once(p.to_path_buf()))
                .find(|c| c.exists())
                .unwrap_or_else(|| self.dir.join(p))
        };
        self.resolved.borrow_mut().push(found.clone());
        found
    }

    /// The files the scene reads besides its root file: included XML files, then every
    /// filename resolved so far, in order, without repeats.
    pub fn inputs(&self) -> Vec<PathBuf> {
        let mut out: Vec<PathBuf> = Vec::new();
        for f in self.files[1..].iter().chain(self.resolved.borrow().iter()) {
            if !out.contains(f) {
                out.push(f.clone());
            }
        }
        out
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
            .and_then(|k| self.node(*k))
            .ok_or_else(|| self.err(node, format!("reference to unknown object \"{id}\"")))?;
        Ok(target)
    }
}
