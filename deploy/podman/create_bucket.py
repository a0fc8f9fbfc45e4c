"""Make the bucket of GUIDED_SFM_ARTIFACTS_URL (s3://BUCKET/PREFIX) if missing: minio-init's job."""

import os
import time
from urllib.parse import urlsplit

import boto3
from botocore.exceptions import ClientError, EndpointConnectionError

bucket = urlsplit(os.environ["GUIDED_SFM_ARTIFACTS_URL"]).netloc
s3 = boto3.client("s3", endpoint_url=os.environ["GUIDED_SFM_S3_ENDPOINT_URL"])
for _ in range(60):  # the server may still be starting
    try:
        s3.head_bucket(Bucket=bucket)
        print(f"bucket {bucket} exists")
        break
    except ClientError:
        s3.create_bucket(Bucket=bucket)
        print(f"bucket {bucket} created")
        break
    except EndpointConnectionError:
        time.sleep(1)
else:
    raise SystemExit("no S3 server answered")
