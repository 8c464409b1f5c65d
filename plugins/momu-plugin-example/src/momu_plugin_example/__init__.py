"""Example momu plugin. Importing the package registers nothing; momu imports the part modules
named by the entry points when a part is asked for."""

__version__ = "0.1.0"
