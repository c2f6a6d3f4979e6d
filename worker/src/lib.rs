//! hexbake's bake kernels, one file per algorithm (STYLE.md habit 1), following
//! paper 000 §3.1 (Chen et al. 2003) and its precursor 003 §4.1.

pub mod backface;
pub mod bake;
pub mod capture;
pub mod capture_memo;
pub mod check;
pub mod classify;
pub mod cli;
pub mod cluster;
pub mod derive;
pub mod diagnostics;
pub mod error;
pub mod far_field;
pub mod grid;
pub mod groups;
pub mod impostor;
pub mod job;
pub mod levels;
pub mod lod_chain;
pub mod mesh_order;
pub mod mvmesh;
pub mod occlusion;
pub mod patches;
pub mod picture;
pub mod proxy;
pub mod raster;
pub mod select;
pub mod selfocc;
pub mod shade;
pub mod simplify;
pub mod svmesh;
pub mod view;
pub mod visibility;
pub mod weights;

/// An error and its causes joined by ": " for people, skipping a cause whose text
/// the message already contains (our error types name their `{source}` in their own
/// message, and `{:#}` would print it once per level).
pub fn error_text(error: &(dyn std::error::Error + 'static)) -> String {
    let mut text = error.to_string();
    let mut cause = error.source();
    while let Some(c) = cause {
        let s = c.to_string();
        if !text.contains(&s) {
            text.push_str(": ");
            text.push_str(&s);
        }
        cause = c.source();
    }
    text
}

#[cfg(test)]
mod tests {
    use super::error_text;

    #[derive(Debug, thiserror::Error)]
    #[error("leaf {0}")]
    struct Leaf(u32);

    #[derive(Debug, thiserror::Error)]
    #[error("middle: {source}")]
    struct Embeds {
        source: Leaf,
    }

    #[derive(Debug, thiserror::Error)]
    #[error("outer")]
    struct Plain {
        source: Embeds,
    }

    #[test]
    fn each_cause_is_named_once() {
        let e = Plain {
            source: Embeds { source: Leaf(7) },
        };
        assert_eq!(error_text(&e), "outer: middle: leaf 7");
        let context = anyhow::Error::new(Embeds { source: Leaf(1) }).context("reading x.ron");
        assert_eq!(
            error_text(context.as_ref()),
            "reading x.ron: middle: leaf 1"
        );
    }
}
