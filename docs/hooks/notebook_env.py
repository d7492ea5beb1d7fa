"""mkdocs hook: the environment the notebooks' kernels run in when the site executes them.

The kernels inherit the build's environment. They plot with matplotlib's inline backend, whatever
`MPLBACKEND` the shell that runs `make docs` has (with `Agg` a kernel draws nothing and the page
has no figures), and without the warning `tqdm.auto` prints, with the path of the file that
raised it, where ipywidgets is not installed (the progress bars are off in the notebooks anyway).
`tests/test_notebooks.py` executes the notebooks in the same environment.
"""

import os

KERNEL_ENVIRONMENT = {
    "MPLBACKEND": "module://matplotlib_inline.backend_inline",
    "PYTHONWARNINGS": "ignore:IProgress not found",
}


def on_config(config):
    """Set the kernels' environment before mkdocs-jupyter starts them."""
    os.environ.update(KERNEL_ENVIRONMENT)
    return config
