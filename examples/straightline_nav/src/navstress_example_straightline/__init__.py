"""navstress-example-straightline: a naive go-to-goal navigator plugged into navstress."""

from navstress_example_straightline.navigator import StraightLineNavigator, stdio_navigator

__all__ = ["StraightLineNavigator", "stdio_navigator"]
