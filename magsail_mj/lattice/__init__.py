"""The lattice shared by the truss and the current-loops concepts: geometry (nodes, struts,
strain check), stiffness properties, the MJCF builder, modes and modal damping."""
