"""Built-in solid FE generator: structured hexahedral meshes, assembly, free-free modes, stress."""
