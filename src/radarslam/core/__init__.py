"""Foundations shared by every other sub-package: angles, linear algebra, validation, event types."""
