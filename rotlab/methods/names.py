"""Method names → the modules that implement them.  Imports nothing, so that validating a
config (``rotlab.config.models``) can check a method name without loading any method.

Adding a method: write ``rotlab/methods/<name>.py`` exposing ``METHOD`` (see
``rotlab.methods.base.Method``) and add one line here.
"""

METHOD_MODULES: dict[str, str] = {
    "rk4": "rotlab.methods.rk4",
    "dop853": "rotlab.methods.dop853",
    "splitting": "rotlab.methods.splitting",
    "dmv": "rotlab.methods.dmv",
    "rkmk4": "rotlab.methods.rkmk4",
    "taylor": "rotlab.methods.taylor",
    "exact": "rotlab.methods.exact",
}

METHOD_NAMES: tuple[str, ...] = ("auto", *METHOD_MODULES)
