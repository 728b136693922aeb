import quatcurve


def test_module_has_version():
    assert quatcurve.__version__ == "0.1.0"
