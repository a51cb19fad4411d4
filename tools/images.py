"""Reading rift's and the peers' images and comparing them, for the scripts in tools/."""
import numpy as np


def read_rgb(path):
    """The beauty of an EXR (its RGBA or RGB channels) as float64 RGB."""
    import OpenEXR

    with OpenEXR.File(str(path)) as f:
        channels = f.channels()
        key = "RGBA" if "RGBA" in channels else "RGB"
        return np.asarray(channels[key].pixels, dtype=np.float64)[..., :3]


def rel_mse(img, ref):
    """Relative mean squared error, with the 0.01 floor `rift bench convergence` uses."""
    return float(np.mean((img - ref) ** 2 / (ref ** 2 + 0.01)))


def rel_variance(a, b, ref):
    """The variance two renders with different seeds show, regularised as `rel_mse` is: half
    their mean squared difference (`rift bench convergence --variance`). The reference's own
    noise does not enter it, nor does bias."""
    return float(np.mean((a - b) ** 2 / (ref ** 2 + 0.01))) / 2
