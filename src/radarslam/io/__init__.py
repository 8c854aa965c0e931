"""Result files and dataset loaders (a leaf: estimation code never imports it)."""
