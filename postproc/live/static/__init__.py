"""Data only: the live view's page, script and style (``server.STATIC_DIR``). A package so that setuptools
installs its files as package data of a declared package (no "absent from packages" warning)."""
