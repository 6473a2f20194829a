//! The record octree (Ward et al. 1988, §3.2): each record lives in the
//! deepest node at least twice as wide as its ball of influence, so a lookup
//! descends from the root only through nodes whose cube, grown by half its
//! width on every side, holds the query point.

use glam::Vec3;

#[derive(Clone, Debug)]
struct Node {
    center: Vec3,
    half: f32,
    children: [u32; 8],
    records: Vec<u32>,
}

/// An octree of balls `(centre, radius)` identified by their index.
#[derive(Clone, Debug)]
pub struct Octree {
    nodes: Vec<Node>,
}

impl Octree {
    /// An empty tree over the cube of half-width `half` about `center`.
    #[must_use]
    pub fn new(center: Vec3, half: f32) -> Self {
        Self {
            nodes: vec![Node {
                center,
                half: half.max(1e-6),
                children: [0; 8],
                records: vec![],
            }],
        }
    }

    /// Inserts ball `id` at `p` with radius `r` (a point outside the root
    /// cube stays in the root, which every lookup tests).
    pub fn insert(&mut self, id: u32, p: Vec3, r: f32) {
        let mut k = 0usize;
        loop {
            let (c, h) = (self.nodes[k].center, self.nodes[k].half);
            let inside = (p - c).abs().max_element() <= h;
            if !inside || h * 0.5 < r || h < 1e-5 {
                self.nodes[k].records.push(id);
                return;
            }
            let o =
                usize::from(p.x > c.x) | usize::from(p.y > c.y) << 1 | usize::from(p.z > c.z) << 2;
            if self.nodes[k].children[o] == 0 {
                let s = Vec3::new(
                    if o & 1 != 0 { 1.0 } else { -1.0 },
                    if o & 2 != 0 { 1.0 } else { -1.0 },
                    if o & 4 != 0 { 1.0 } else { -1.0 },
                );
                self.nodes.push(Node {
                    center: c + s * (h * 0.5),
                    half: h * 0.5,
                    children: [0; 8],
                    records: vec![],
                });
                self.nodes[k].children[o] = (self.nodes.len() - 1) as u32;
            }
            k = self.nodes[k].children[o] as usize;
        }
    }

    /// Calls `f` with every ball whose node's grown cube holds `p` (a
    /// superset of the balls containing `p`).
    pub fn for_each_near(&self, p: Vec3, mut f: impl FnMut(u32)) {
        let mut stack = [0u32; 256];
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let n = &self.nodes[stack[top] as usize];
            for &id in &n.records {
                f(id);
            }
            for &c in &n.children {
                if c != 0 {
                    let cn = &self.nodes[c as usize];
                    if (p - cn.center).abs().max_element() <= 2.0 * cn.half && top < stack.len() {
                        stack[top] = c;
                        top += 1;
                    }
                }
            }
        }
    }

    /// Number of nodes.
    #[must_use]
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }
}
