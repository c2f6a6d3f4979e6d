//! Model loaders: glTF/GLB, OBJ, PLY, OFF, STL → [`Mesh`](crate::Mesh).
//!
//! TODO(issue 2): loaders, welding, smooth normals, degenerate removal, normalisation.
