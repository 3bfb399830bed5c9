"""The transformation methods, one module each (see :mod:`.base` for what a method is)."""

from fuzzymbs.fuzzy.methods.base import Method, OptionInfo
from fuzzymbs.fuzzy.methods.registry import METHODS, method_named, option_users

__all__ = ["METHODS", "Method", "OptionInfo", "method_named", "option_users"]
