var SY=null,CODE0=__CODE_0__,ML=__MAG_LEVELS__,PL=__PHASE_LEVELS__;
function syDecode(){var s=d.sy,L=s.levels,n=s.n,rows=[];
 for(var k=0;k<s.rows;k++){var re=new Float64Array(n),im=new Float64Array(n);
  for(var j=0;j<n;j++){var c=L.charCodeAt(k*n+j)-CODE0,lv=Math.floor(c/PL),
   m=Math.pow(10,s.lmin[k]+lv/ML*(s.lmax[k]-s.lmin[k])),ph=(c-lv*PL)/PL*2*Math.PI-Math.PI;
   re[j]=m*Math.cos(ph);im[j]=m*Math.sin(ph);}
  rows.push([re,im]);}
 return rows;}
function syBasis(freqs,lams){
 var s=d.sy,n=freqs.length,res=[],cols=[];if(s.low)res.push(s.q-2);if(s.up)res.push(s.q);
 lams.forEach(function(l){var a=l[0],b=l[1],c1=[new Float64Array(n),new Float64Array(n)],
  c2=[new Float64Array(n),new Float64Array(n)];
  for(var j=0;j<n;j++){var w=2*Math.PI*freqs[j],d1=a*a+(w-b)*(w-b),d2=a*a+(w+b)*(w+b),
   gr=-a/d1,gi=-(w-b)/d1,cr=-a/d2,ci=-(w+b)/d2;
   c1[0][j]=gr+cr;c1[1][j]=gi+ci;c2[0][j]=-(gi-ci);c2[1][j]=gr-cr;}
  cols.push(c1,c2);});
 res.forEach(function(p){var c1=[new Float64Array(n),new Float64Array(n)],
  c2=[new Float64Array(n),new Float64Array(n)],k=((p%4)+4)%4;
  for(var j=0;j<n;j++){var w=2*Math.PI*freqs[j],m=(w===0&&p<0)?0:Math.pow(w,p),
   r=[m,0,-m,0][k],i=[0,m,0,-m][k];c1[0][j]=r;c1[1][j]=i;c2[0][j]=-i;c2[1][j]=r;}
  cols.push(c1,c2);});
 return cols;}
function synthesis(lams){
 var s=d.sy;if(!s||!s.n||!lams.length||!d.fl.length)return null;
 if(!SY)SY=syDecode();
 var fit=[];for(var j=0;j<s.n;j++)fit.push(s.f0+j*s.df);
 var G=syBasis(fit,lams),p=G.length,M=[],sc=[],i,j,k,t;
 for(i=0;i<p;i++){M.push(new Float64Array(p));}
 for(i=0;i<p;i++){for(j=0;j<=i;j++){t=0;var ar=G[i][0],ai=G[i][1],br=G[j][0],bi=G[j][1];
  for(k=0;k<s.n;k++){t+=ar[k]*br[k]+ai[k]*bi[k];}M[i][j]=M[j][i]=t;}}
 for(i=0;i<p;i++){sc.push(M[i][i]>0?Math.sqrt(M[i][i]):1);}
 for(i=0;i<p;i++){for(j=0;j<p;j++){M[i][j]/=sc[i]*sc[j];}M[i][i]+=1e-10;}
 for(j=0;j<p;j++){t=M[j][j];for(k=0;k<j;k++){t-=M[j][k]*M[j][k];}
  M[j][j]=Math.sqrt(Math.max(t,1e-300));
  for(i=j+1;i<p;i++){t=M[i][j];for(k=0;k<j;k++){t-=M[i][k]*M[j][k];}M[i][j]=t/M[j][j];}}
 var X=SY.map(function(y){var x=new Float64Array(p);
  for(i=0;i<p;i++){t=0;for(k=0;k<s.n;k++){t+=G[i][0][k]*y[0][k]+G[i][1][k]*y[1][k];}
   x[i]=t/sc[i];}
  for(i=0;i<p;i++){t=x[i];for(k=0;k<i;k++){t-=M[i][k]*x[k];}x[i]=t/M[i][i];}
  for(i=p-1;i>=0;i--){t=x[i];for(k=i+1;k<p;k++){t-=M[k][i]*x[k];}x[i]=t/M[i][i];}
  for(i=0;i<p;i++){x[i]/=sc[i];}return x;});
 var nd=d.fl.length,fd=[];for(j=0;j<nd;j++)fd.push(d.f0+j*d.df);
 var B=syBasis(fd,lams),S=X.map(function(x){var re=new Float64Array(nd),
  im=new Float64Array(nd);for(i=0;i<p;i++){var c=B[i];
  for(k=0;k<nd;k++){re[k]+=x[i]*c[0][k];im[k]+=x[i]*c[1][k];}}return [re,im];});
 var out=new Float64Array(nd);
 if(s.mix){s.mix.forEach(function(u){for(k=0;k<nd;k++){var r=0,m=0;
   for(i=0;i<u.length;i++){r+=u[i]*S[i][0][k];m+=u[i]*S[i][1][k];}
   out[k]+=Math.sqrt(r*r+m*m);}});}
 else{S.forEach(function(z){for(k=0;k<nd;k++){out[k]+=Math.hypot(z[0][k],z[1][k]);}});}
 for(k=0;k<nd;k++){out[k]=Math.log10(Math.max(out[k],1e-300));}
 return out;}