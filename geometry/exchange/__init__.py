"""Exchange with aero-design tools: BladeGen/TurboGrid curve files and CFturbo ``.cft-geo``.

``geometry.exchange.command`` holds ``impeller-cam import`` and ``export``; the formats,
their sources and what is not supported are in docs/import-export.md.
"""
