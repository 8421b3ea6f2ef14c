"""Any spacecraft structure: the structure model, its file format, generators, importers (gmsh
meshes, Nastran decks), modal analysis and the MuJoCo model built from it."""
