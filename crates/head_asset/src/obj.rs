//! A small Wavefront OBJ reader: positions, polygon faces and the groups they belong to.
//!
//! Texture coordinates, normals, materials and smoothing groups are read past: the head
//! needs only its shape. Indices may be absolute (1-based) or relative (negative).

use crate::error::Error;

/// The geometry of an OBJ file.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Obj {
    /// Every `v` line, in file order, in the file's units.
    pub positions: Vec<[f64; 3]>,
    /// Every `f` line, in file order.
    pub faces: Vec<Face>,
    /// Group names in order of first appearance; [`Face::groups`] indexes into this.
    pub groups: Vec<String>,
}

/// One polygon of an OBJ file.
#[derive(Clone, Debug, PartialEq)]
pub struct Face {
    /// 0-based indices into [`Obj::positions`], in the file's winding order.
    pub vertices: Vec<u32>,
    /// The groups (indices into [`Obj::groups`]) active when the face was read.
    pub groups: Vec<u32>,
}

impl Obj {
    /// Parses OBJ text. Fails on malformed `v` or `f` lines and on indices that point at
    /// vertices that do not exist.
    pub fn parse(text: &str) -> Result<Obj, Error> {
        let mut obj = Obj::default();
        let mut current: Vec<u32> = vec![obj.group_index("default")];
        for (n, line) in text.lines().enumerate() {
            let err = |message: String| Error::Obj { line: n + 1, message };
            let line = line.split('#').next().unwrap_or("");
            let mut words = line.split_whitespace();
            match words.next() {
                Some("v") => {
                    let mut p = [0.0f64; 3];
                    for (k, c) in p.iter_mut().enumerate() {
                        let word = words.next().ok_or_else(|| err(format!("`v` needs 3 coordinates, has {k}")))?;
                        *c = word.parse().map_err(|_| err(format!("`{word}` is not a number")))?;
                        if !c.is_finite() {
                            return Err(err(format!("coordinate `{word}` is not finite")));
                        }
                    }
                    obj.positions.push(p);
                }
                Some("f") => {
                    let mut vertices = Vec::new();
                    for word in words {
                        let index = word.split('/').next().unwrap_or("");
                        let index: i64 = index.parse().map_err(|_| err(format!("`{word}` is not a vertex index")))?;
                        let count = obj.positions.len() as i64;
                        let resolved = if index < 0 { count + index } else { index - 1 };
                        if index == 0 || !(0..count).contains(&resolved) {
                            return Err(err(format!("vertex index {index} with {count} vertices read so far")));
                        }
                        vertices.push(resolved as u32);
                    }
                    if vertices.len() < 3 {
                        return Err(err(format!("a face needs at least 3 vertices, has {}", vertices.len())));
                    }
                    obj.faces.push(Face { vertices, groups: current.clone() });
                }
                Some("g") => {
                    let names: Vec<&str> = words.collect();
                    current = if names.is_empty() {
                        vec![obj.group_index("default")]
                    } else {
                        names.iter().map(|name| obj.group_index(name)).collect()
                    };
                }
                _ => {}
            }
        }
        Ok(obj)
    }

    fn group_index(&mut self, name: &str) -> u32 {
        match self.groups.iter().position(|g| g == name) {
            Some(i) => i as u32,
            None => {
                self.groups.push(name.to_owned());
                self.groups.len() as u32 - 1
            }
        }
    }

    /// The faces that belong to group `name`, in file order, or an error naming the groups
    /// the file has.
    pub fn group_faces(&self, name: &str) -> Result<Vec<&Face>, Error> {
        let missing = || Error::MissingGroup {
            group: name.to_owned(),
            available: self
                .groups
                .iter()
                .enumerate()
                .filter(|&(g, _)| self.faces.iter().any(|f| f.groups.contains(&(g as u32))))
                .map(|(_, name)| name.clone())
                .collect(),
        };
        let group = self.groups.iter().position(|g| g == name).ok_or_else(missing)? as u32;
        let faces: Vec<&Face> = self.faces.iter().filter(|f| f.groups.contains(&group)).collect();
        if faces.is_empty() { Err(missing()) } else { Ok(faces) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SQUARE: &str = "# a unit square in two groups\n\
        v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\n\
        g body\ns off\nf 1/1 2/1 3/1 4/1\n\
        g helper-eye\nf -4//1 -2//1 -1//1\n";

    #[test]
    fn reads_positions_faces_and_groups() {
        let obj = Obj::parse(SQUARE).unwrap();
        assert_eq!(obj.positions.len(), 4);
        assert_eq!(obj.positions[2], [1.0, 1.0, 0.0]);
        assert_eq!(obj.groups, ["default", "body", "helper-eye"]);
        let body = obj.group_faces("body").unwrap();
        assert_eq!(body.len(), 1);
        assert_eq!(body[0].vertices, [0, 1, 2, 3]);
        let eye = obj.group_faces("helper-eye").unwrap();
        assert_eq!(eye[0].vertices, [0, 2, 3], "negative indices count back from the last vertex");
    }

    #[test]
    fn errors_name_the_line_and_the_groups() {
        let err = Obj::parse("v 0 0 0\nv 1 0 0\nf 1 2 9\n").unwrap_err();
        assert!(matches!(err, Error::Obj { line: 3, .. }), "{err}");
        let err = Obj::parse("v 0 0 zero\n").unwrap_err();
        assert!(err.to_string().contains("`zero` is not a number"), "{err}");
        let err = Obj::parse(SQUARE).unwrap().group_faces("head").unwrap_err();
        assert_eq!(err.to_string(), "the OBJ has no faces in group `head` (groups: body, helper-eye)");
    }
}
