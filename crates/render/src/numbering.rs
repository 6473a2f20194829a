//! How messages name a scene's objects and lights.
//!
//! Code indexes [`crate::Scene::objects`], `point_lights` and `area_lights`
//! from 0. People read them from 1: the scene file's loader names the
//! first `[[object]]` table `object[1]`, and `relight info` lists
//! `object 1`, `object 2`, … So every warning and error that names one
//! goes through [`Numbered`], the one place where an index becomes a
//! number, and a message from a method reads like the scene's own.

use std::fmt;

/// `"object 3"` for index 2: the kind and its 1-based number.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Numbered {
    kind: &'static str,
    index: usize,
}

impl Numbered {
    /// `scene.objects[index]`.
    #[must_use]
    pub const fn object(index: usize) -> Self {
        Self {
            kind: "object",
            index,
        }
    }

    /// `scene.point_lights[index]`.
    #[must_use]
    pub const fn point_light(index: usize) -> Self {
        Self {
            kind: "point light",
            index,
        }
    }

    /// `scene.area_lights[index]`.
    #[must_use]
    pub const fn area_light(index: usize) -> Self {
        Self {
            kind: "area light",
            index,
        }
    }
}

impl fmt::Display for Numbered {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {}", self.kind, self.index + 1)
    }
}

#[cfg(test)]
mod tests {
    use super::Numbered;

    #[test]
    fn indices_read_from_one() {
        assert_eq!(Numbered::object(0).to_string(), "object 1");
        assert_eq!(Numbered::point_light(2).to_string(), "point light 3");
        assert_eq!(Numbered::area_light(1).to_string(), "area light 2");
    }
}
