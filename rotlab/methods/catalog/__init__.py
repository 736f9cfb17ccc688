"""The methods: one module per method, named as the method (``solver.method``), each exposing
``METHOD`` (``rotlab.methods.base.Method``).  A module here is picked up by name
(``rotlab.method_names``) and loaded on first use (``rotlab.methods.registry``)."""
