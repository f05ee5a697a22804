"""Results on disk and on screen: :mod:`.xdmf` (the XDMF/HDF5 time series ParaView opens, and reading it back
as a start), :mod:`.fields` (contact quantities as mesh fields and per-pair forces), :mod:`.summary`
(summary.json and the CSV files), :mod:`.results` (a result directory written whole or not at all),
:mod:`.figures` (PNG figures) and :mod:`.display` (a virtual X display for them)."""
