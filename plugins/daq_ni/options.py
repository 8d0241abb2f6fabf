"""The ``ni`` backend's own options: what `odsuite plugins` and `odsuite acquire` read without
importing the backend."""

from odsuite.contracts.backend_options import BackendOption  # not .daq: registering imports no more

OPTIONS = (BackendOption("device", str, "Dev1", "device name as in NI MAX"),
           BackendOption("trigger_source", str, None,
                         "digital trigger terminal, e.g. /Dev1/PFI0 (default: analog on the force channel)"),
           BackendOption("iepe", bool, True, "plain voltage channels (external conditioning) instead of IEPE",
                         flag="--voltage", when_given=False))
