"""Where model artifacts live: a local folder (default) or an S3-compatible bucket.

``DRX_ARTIFACTS_URL`` picks the store: unset, a folder or ``file://`` URL keeps every
model's files on this machine (``$DRX_HOME/artifacts``); ``s3://bucket/prefix`` keeps
them in AWS S3 or any S3-compatible store (MinIO, Ceph; the endpoint and credentials come
from the standard AWS environment: ``AWS_ENDPOINT_URL``, ``AWS_ACCESS_KEY_ID``...).

Either way drx reads and writes a model's files in a local folder
(:meth:`ArtifactStore.model_dir`); with a bucket that folder is this host's cache, and the
store's :meth:`~ArtifactStore.pull` / :meth:`~ArtifactStore.push` move files between the two
(atomically: a download is renamed into place, an upload is one PUT).
"""

from drx.storage.base import ArtifactStore, LocalStore
from drx.storage.select import artifacts_dir, get_store, reset_stores, store_url

__all__ = ["ArtifactStore", "LocalStore", "artifacts_dir", "get_store", "reset_stores", "store_url"]
