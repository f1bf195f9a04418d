"""opnet.testing.check_inner_product: passes the built-ins, names each failed property of a faulty one."""

import importlib.util

import numpy as np
import pytest

import opnet
from opnet.testing import check_inner_product


class Height(opnet.InnerProduct):
    """A valid inner product that is not rigid-invariant: mass weighted by the height above z = -2."""

    name = "height"

    def project(self, vertices, faces, evecs):
        w = opnet.vertex_areas(vertices, faces) * (vertices[:, 2] + 2.0) ** 2
        return evecs.T @ (w[:, None] * evecs)


class Negative(opnet.InnerProduct):
    def project(self, vertices, faces, evecs):
        return -evecs.T @ (opnet.vertex_areas(vertices, faces)[:, None] * evecs)


class BadBatch(opnet.InnerProduct):
    def project(self, vertices, faces, evecs):
        return evecs.T @ (opnet.vertex_areas(vertices, faces)[:, None] * evecs)

    def project_batch(self, vertices, faces, evecs):
        return np.stack([self.project(vertices[0], faces, evecs)] * len(vertices))  # forgets all but the first


class NotSymmetric(opnet.InnerProduct):
    def project(self, vertices, faces, evecs):
        return np.triu(np.ones((evecs.shape[1],) * 2))


def test_the_built_in_inner_products_pass_and_are_rigid_invariant(base):
    torch_checked = True if importlib.util.find_spec("torch") else None  # a core-only install cannot run it
    for kind in opnet.KINDS:
        assert check_inner_product(kind, base, k=10) == {
            "symmetric": True,
            "psd": True,
            "batch_equals_single": True,
            "torch_equals_numpy": torch_checked,
            "rigid_invariant": True,
        }


def test_a_wrong_torch_form_is_found(base):
    pytest.importorskip("torch")

    class Off(opnet.InnerProduct):
        name = "off by a bit"

        def project(self, vertices, faces, evecs):
            return opnet.AreaInnerProduct().project(vertices, faces, evecs)

        def project_torch(self, vertices, faces, evecs):
            return 1.01 * opnet.AreaInnerProduct().project_torch(vertices, faces, evecs)

    with pytest.raises(AssertionError, match="project_torch differs from project"):
        check_inner_product(Off(), base, k=10)


def test_a_valid_but_position_dependent_inner_product_is_reported_not_refused(base):
    result = check_inner_product(Height(), base, k=10)
    assert result["psd"] and result["batch_equals_single"] and not result["rigid_invariant"]


@pytest.mark.parametrize(
    "ip, message",
    [
        (Negative(), "fails 1 of .*not positive semi-definite"),
        (BadBatch(), "fails 1 of .*project_batch differs"),
        (NotSymmetric(), "not an inner product.*non-symmetric"),
    ],
)
def test_each_failed_property_is_named(base, ip, message):
    with pytest.raises(AssertionError, match="(?s)" + message):
        check_inner_product(ip, base, k=10)
    with pytest.raises(TypeError, match="opnet.Mesh"):
        check_inner_product(ip, base.vertices)
