"""drape from Python: read garment releases and run the runtime (recognition,
registration, feature matching) through drape's C++ libraries.

    import drape
    r = drape.open_release("build/quickstart")
    e = r.entries(split="test")[0]
    V, F = e.hang_mesh()          # numpy (V, 3) float64, (F, 3) int32
    bits = e.feature()            # numpy bool (layers, rings, sectors)
    print(r.recognize(entry=e.id).anchor)

Every algorithm and file format is the C++ one (module drape._drape); this package
converts to numpy and plain Python objects. `drape.torch.GarmentDataset` is a PyTorch
dataset over a release (import drape.torch; needs python3-torch).
"""

from ._drape import DrapeError
from ._release import (Entry, Recognition, Release, ReleaseNotFoundError, open_release)
from ._runtime import extract_feature, match, register, Registration

__all__ = [
    "DrapeError", "ReleaseNotFoundError", "open_release", "Release", "Entry", "Recognition",
    "register", "Registration", "match", "extract_feature",
]
