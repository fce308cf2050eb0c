"""Pure builders of what a scene is made of, no simulator: procedural and household meshes,
texture tiles and their UV mapping, users' mesh and picture folders, and layouts (backdrop
rooms, the tabletop). Worlds turn their values into simulator objects."""
