"""PointCloud2 helpers shared by the scripts and the rostests (numpy only, no ROS import)."""
import numpy as np


def xyz(msg):
    """The cloud's x y z as an (n, 3) float array (any point layout with float32 x y z)."""
    offsets = {f.name: f.offset for f in msg.fields}
    dtype = np.dtype({"names": ["x", "y", "z"], "formats": ["<f4"] * 3,
                      "offsets": [offsets["x"], offsets["y"], offsets["z"]],
                      "itemsize": msg.point_step})
    points = np.frombuffer(msg.data, dtype=dtype, count=msg.width * msg.height)
    return np.stack([points["x"], points["y"], points["z"]], axis=1).astype(np.float64)


def quaternion_matrix(xyzw):
    """3 x 3 rotation of a unit quaternion (x, y, z, w)."""
    x, y, z, w = xyzw
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
