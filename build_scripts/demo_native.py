"""A small demonstration of the native core on the seed's worked examples."""

import quatcurve

print("quatcurve", quatcurve.__version__)
