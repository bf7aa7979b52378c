"""Robot files in: YAML with positions (``loader``), validation into a ``Robot`` (``schema``),
URDF (``urdf``) and the JSON Schema of the format (``json_schema``). The only layer, with
``commands``, that reads files."""
