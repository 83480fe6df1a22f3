"""The results of a study on disk: where files live (``layout``), the records they hold
(``records``), how they are written and read (``storage``) and where an archive lives
(``archive_url``). The tables a calibration exports are ``demcal.daemon.tables``."""
