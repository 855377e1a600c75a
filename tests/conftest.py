import numpy as np
import pytest

from hydrohil.parameters import load_parameters

EXAMPLES = __import__("pathlib").Path(__file__).resolve().parent.parent / "examples"


@pytest.fixture(scope="session")
def paper():
    return load_parameters("ferreira2004")


def rms(e):
    return float(np.sqrt(np.mean(np.asarray(e) ** 2)))
