"""Exports of a World to other tools: Gazebo SDF, glTF/OBJ meshes, heightmap and preview PNGs.

The standalone MuJoCo model (MJCF) is built by ``navstress.sim.model.world_to_mjcf``.
Submodules are imported on use (matplotlib and trimesh are slow to import).
"""

__all__ = ["images", "mesh", "sdf"]
